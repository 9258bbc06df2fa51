"""The real command, list path against windowed (GCODE_OPT_WINDOWED=1): CPU (user + system)
and peak RSS (ru_maxrss) of the child process, rounds interleaved, medians; and whether each
run wrote the reference's bytes and JSON (every key but timing_s, elapsed_s, output).

    python benchmarks/wire53_command.py REF_TREE [--rounds 3] [--files rect,gyroid,small] [--windows 1024]

REF_TREE: the tree whose output is the reference (the list path's bytes: /work/main at
182bdeb); the runs are this checkout's, `python -m gcode_opt process FILE -o OUT --json J -q
--profile P` as bench_command.py runs it (its FILES)."""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, ".."))
sys.path.insert(0, HERE)

from bench_command import FILES, child  # noqa: E402

VOLATILE = ("timing_s", "elapsed_s", "output")


def command(tree, f, prof, out, env):
    return child([sys.executable, "-m", "gcode_opt", "process", f, "-o", out, "--json", out + ".json", "-q",
                  "--profile", prof], dict(os.environ, PYTHONPATH=tree, **env), tree)


SAME = ("import json, sys\n"
        "a, b = sys.argv[1:3]\n"
        "same = open(a, 'rb').read() == open(b, 'rb').read()\n"
        "ja, jb = json.load(open(a + '.json')), json.load(open(b + '.json'))\n"
        f"print(json.dumps([same, sorted(k for k in set(ja) | set(jb) if k not in {VOLATILE!r} "
        "and ja.get(k) != jb.get(k))]))\n")


def same(a, b):
    """(same bytes, the JSON keys that differ but VOLATILE), read in a child process: the
    summaries read here would raise this process's peak RSS, which a child forked after
    inherits (Linux folds the parent's high-water mark into the child's ru_maxrss at exec)"""
    out = subprocess.run([sys.executable, "-c", SAME, a, b], capture_output=True, text=True, check=True).stdout
    return tuple(json.loads(out))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ref")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--files", default="rect,gyroid,small")
    ap.add_argument("--windows", default="1024", help="comma-separated GCODE_OPT_WINDOW values")
    a = ap.parse_args(argv)
    tmp = tempfile.mkdtemp(prefix="wire53_")
    for tree in (a.ref, ROOT):
        subprocess.run([sys.executable, "-m", "compileall", "-q", os.path.join(tree, "gcode_opt")], check=True)
    modes = [("list", {})] + [(f"win{w}", {"GCODE_OPT_WINDOWED": "1", "GCODE_OPT_WINDOW": w})
                              for w in a.windows.split(",")]
    res = {}
    for n in a.files.split(","):
        f, prof = FILES[n]
        ref = os.path.join(tmp, f"{n}_ref.gcode")
        command(os.path.abspath(a.ref), f, prof, ref, {})
        for rnd in range(a.rounds):
            for mode, env in modes:
                out = os.path.join(tmp, f"{n}_{mode}.gcode")
                t, m, rc = command(ROOT, f, prof, out, env)
                ok = same(ref, out) if rc == 0 else (False, [f"exit {rc}"])
                res.setdefault((n, mode), []).append((t, m, ok))
                print(f"{rnd} {n:<7} {mode:<8} CPU {t:6.2f} s  peak RSS {m:6.1f} MB  same bytes {ok[0]}  "
                      f"json differs {ok[1]}", flush=True)
    print("medians:")
    for (n, mode), v in res.items():
        print(f"  {n:<7} {mode:<8} CPU {statistics.median(x[0] for x in v):6.2f} s  "
              f"peak RSS {statistics.median(x[1] for x in v):6.1f} MB  "
              f"same bits every run: {all(x[2][0] and not x[2][1] for x in v)}")


if __name__ == "__main__":
    main()
