"""`python -m gcode_opt` ends by cli.exit_process: os._exit where the interpreter's teardown
has nothing left to do for the run, else sys.exit.  The process's exit status, its stdout
and stderr (pipes: buffered) and the files it writes are those of sys.exit(main()); an
atexit callback still runs (then the usual exit is taken), and a run of __main__ inside
another program (runpy, as tests do) returns to it."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SAMPLE = ROOT / "sample_gcode" / "prusa_mk3s_rectilinear.gcode"
ENV = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
ENV.pop("PYTHONUNBUFFERED", None)           # (stdout and stderr pipes buffered, as usual)
USUAL = "import sys; from gcode_opt.cli import main; sys.exit(main())"
# what pip's `gcode-opt` wrapper runs (pyproject's console script: cli.run)
SCRIPT = "import sys; sys.argv[0] = 'gcode-opt'; from gcode_opt.cli import run; sys.exit(run())"


def _scrub(o):
    if isinstance(o, dict):
        return {k: _scrub(v) for k, v in o.items()
                if k not in ("output", "input", "elapsed_s", "timing_s", "peak_rss_mb")}
    return [_scrub(v) for v in o] if isinstance(o, list) else o


def _run(args, cwd):
    return subprocess.run([sys.executable] + args, cwd=str(cwd), env=ENV, capture_output=True, timeout=600)


def _cases(tmp_path):
    small = tmp_path / "in.gcode"
    small.write_text("G28\nG1 X10 Y10 E1 F1200\n")
    yield ["profiles"], None
    yield ["simulate", str(small)], None
    yield ["process", str(SAMPLE), "-o", "OUT", "--json", "JSON"], ("OUT", "JSON")
    yield ["process", str(small), "-o", "OUT"], ("OUT",)
    yield ["process", str(tmp_path / "no such file.gcode"), "-o", "OUT"], ("OUT",)
    yield ["process", str(small), "--no-such-option"], None


def test_the_fast_exit_is_the_usual_exit(tmp_path):
    for k, (args, outs) in enumerate(_cases(tmp_path)):
        got = {}
        for way, head in (("fast", ["-m", "gcode_opt"]), ("usual", ["-c", USUAL]), ("script", ["-c", SCRIPT])):
            d = tmp_path / f"{way}{k}"
            d.mkdir()
            p = _run(head + args, d)
            files = {o: (d / o).read_bytes() if (d / o).exists() else None for o in (outs or ())}
            if files.get("JSON") is not None:         # (its timings and paths differ run to run)
                files["JSON"] = _scrub(json.loads(files["JSON"]))
            got[way] = (p.returncode, p.stdout, p.stderr.replace(str(d).encode(), b"D"), files)
        assert got["fast"] == got["usual"], args
        assert got["script"] == got["usual"], args
        if args[0] == "profiles":
            assert got["fast"][1]          # (stdout a pipe: all of it flushed)


def test_an_atexit_callback_still_runs(tmp_path):
    code = ("import atexit, runpy, sys\n"
            "atexit.register(lambda: print('atexit ran', flush=True))\n"
            "sys.argv = ['gcode_opt', 'profiles']\n"
            "runpy.run_module('gcode_opt', run_name='__main__', alter_sys=True)\n")
    p = _run(["-c", code], tmp_path)
    assert p.returncode == 0 and p.stdout.rstrip().endswith(b"atexit ran")


def test_run_inside_another_program_returns_to_it(tmp_path):
    code = ("import runpy, sys\n"
            "sys.argv = ['gcode_opt', 'profiles']\n"
            "try:\n    runpy.run_module('gcode_opt', run_name='__main__')\n"
            "except SystemExit as e:\n    print('returned', e.code)\n")
    p = _run(["-c", code], tmp_path)
    assert p.returncode == 0 and p.stdout.rstrip().endswith(b"returned 0")


@pytest.mark.parametrize("code", [0, 2, 3, None])
def test_exit_codes(tmp_path, code):
    py = ("import sys; sys.argv = ['x']\n"
          "from gcode_opt.cli import exit_process\n"
          "print('out', end='')\n"
          f"exit_process({code!r})\n")
    p = _run(["-c", py], tmp_path)
    assert p.returncode == (code or 0) and p.stdout == b"out"


def test_the_console_script_ends_by_exit_process():
    """pyproject's `gcode-opt` is cli.run (main, then exit_process), so a slicer's run of
    the installed program ends as `python -m gcode_opt` does."""
    text = (ROOT / "pyproject.toml").read_text()
    assert 'gcode-opt = "gcode_opt.cli:run"' in text
    from gcode_opt import cli
    calls = []
    saved = cli.main, cli.exit_process
    try:
        cli.main, cli.exit_process = (lambda: 3), calls.append
        cli.run()
    finally:
        cli.main, cli.exit_process = saved
    assert calls == [3]
