"""The whole `gcode-opt process` command, as a slicer runs it: CPU time and peak RSS of the
child process (interpreter start and imports included), side by side for one or more source
trees, with a bare read-split-write loop over the same file in the same round.

    python benchmarks/bench_command.py [TREE[:TAG] ...] [--rounds N] [--files gyroid,rect,...] [--pure]

TREE is a checkout of gcode-opt with its compiled cores built (`python setup.py build_ext
--inplace`); without one, this checkout.  Compare two versions with a second worktree:

    git worktree add --detach /tmp/old COMMIT && (cd /tmp/old && python setup.py -q build_ext --inplace)
    python benchmarks/bench_command.py /tmp/old:old .:new

Each round runs the bare loop and then every tree on every file, so a round's figures share
the machine's load; the table gives every round (not only a median: on a shared machine the
spread is the honest figure).  CPU is user + system of the child (`os.wait4`), peak RSS its
`ru_maxrss`.  Every tree's bytecode is compiled first, as an install leaves it: with
PYTHONDONTWRITEBYTECODE set, a module changed since its last .pyc would otherwise be compiled
again in every run (~0.1-0.3 s, not a cost a user pays).

The large files are sample_gcode/make_corpus.sh's plates (in ~/.cache/gcode-opt-corpus).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, ".."))
CORPUS = os.path.join(os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "gcode-opt-corpus")
FILES = {     # name: (file, profile)
    "gyroid": (os.path.join(CORPUS, "plate_gyroid.gcode"), "prusa-mk3s"),
    "rect": (os.path.join(CORPUS, "plate_rectilinear.gcode"), "prusa-mk3s"),
    "gyroid_v24": (os.path.join(CORPUS, "plate_gyroid.gcode"), "voron24"),
    "small": (os.path.join(ROOT, "sample_gcode", "prusa_gyroid.gcode"), "prusa-mk3s"),
    # Marlin 2's junction deviation (session 55): the plate for a generic Marlin 2 printer, and
    # a real Cura file (make_corpus.sh) for an Ender 3
    "gyroid_marlin2": (os.path.join(CORPUS, "plate_gyroid.gcode"), "generic-marlin"),
    "cura_gyroid": (os.path.join(CORPUS, "cura_gyroid.gcode"), "ender3"),
}
BARE = ("import sys\n"
        "with open(sys.argv[1], newline='') as fi, open(sys.argv[2], 'w', newline='') as fo:\n"
        "    for raw in fi:\n"
        "        raw.split()\n"
        "        fo.write(raw)\n")


def child(cmd, env, cwd=None):
    """(CPU s, peak RSS MB, exit status) of one child process."""
    p = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(p.pid, 0)
    return ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0, os.waitstatus_to_exitcode(status)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trees", nargs="*", help="TREE[:TAG] (default: this checkout)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--files", default="gyroid,rect,small", help=f"comma-separated, of {', '.join(FILES)}")
    ap.add_argument("--pure", action="store_true", help="GCODE_OPT_PURE_PYTHON=1 (no compiled cores)")
    ap.add_argument("--tmp", default=None, help="folder for the outputs (default: a temporary one)")
    a = ap.parse_args(argv)
    trees = []
    for spec in a.trees or [ROOT]:
        path, _, tag = spec.partition(":")
        trees.append((os.path.abspath(path), tag or os.path.basename(os.path.abspath(path))))
    names = [n for n in a.files.split(",") if n]
    for n in names:
        if n not in FILES:
            ap.error(f"unknown file {n!r}: one of {', '.join(FILES)}")
        if not os.path.exists(FILES[n][0]):
            ap.error(f"{FILES[n][0]} is missing: make it with `bash sample_gcode/make_corpus.sh`")
    import tempfile
    tmp = os.path.abspath(a.tmp or tempfile.mkdtemp(prefix="bench_command_"))
    os.makedirs(tmp, exist_ok=True)
    py = sys.executable
    for path, tag in trees:
        # each tree's runs start in the tree (`python -m` puts the working folder first on
        # the path, ahead of PYTHONPATH: run from another checkout, they would all run that
        # one); check that the package imported is the tree's
        got = subprocess.run([py, "-c", "import gcode_opt; print(gcode_opt.__file__)"], cwd=path, text=True,
                             env=dict(os.environ, PYTHONPATH=path), capture_output=True, check=True).stdout.strip()
        if not os.path.realpath(got).startswith(os.path.realpath(path) + os.sep):
            sys.exit(f"bench_command: {tag} imports {got}, not its own tree {path}")
        subprocess.run([py, "-m", "compileall", "-q", os.path.join(path, "gcode_opt")], check=True)
    lines = {n: sum(1 for _ in open(FILES[n][0], "rb")) for n in names}
    res = {}
    print(f"{'round':>5} {'file':<11} {'tree':<10} {'CPU s':>7} {'k lines/s':>10} {'x bare':>7} {'peak RSS MB':>12}")
    for rnd in range(a.rounds):
        for n in names:
            f, prof = FILES[n]
            t_bare, m_bare, rc = child([py, "-c", BARE, f, os.path.join(tmp, "bare.out")], dict(os.environ))
            if rc != 0:
                sys.exit(f"bench_command: the bare loop failed on {f} (exit {rc})")
            res.setdefault((n, "bare"), []).append((t_bare, m_bare))
            print(f"{rnd:>5} {n:<11} {'bare loop':<10} {t_bare:7.2f} {lines[n] / t_bare / 1e3:10.0f} {1.0:7.1f} {m_bare:12.1f}",
                  flush=True)
            for path, tag in trees:
                env = dict(os.environ, PYTHONPATH=path)
                if a.pure:
                    env["GCODE_OPT_PURE_PYTHON"] = "1"
                out = os.path.join(tmp, f"{n}_{tag}.gcode")
                t, m, rc = child([py, "-m", "gcode_opt", "process", f, "-o", out, "--profile", prof, "-q"], env, path)
                res.setdefault((n, tag), []).append((t, m))
                print(f"{rnd:>5} {n:<11} {tag:<10} {t:7.2f} {lines[n] / t / 1e3:10.0f} {t / t_bare:7.1f} {m:12.1f}"
                      + ("" if rc == 0 else f"  exit {rc}"), flush=True)
    print("medians:")
    for (n, tag), v in res.items():
        t = statistics.median(x[0] for x in v)
        print(f"  {n:<11} {tag:<10} CPU {t:6.2f} s ({lines[n] / t / 1e3:.0f} k lines/s), "
              f"peak RSS {statistics.median(x[1] for x in v):6.1f} MB")


if __name__ == "__main__":
    main()
