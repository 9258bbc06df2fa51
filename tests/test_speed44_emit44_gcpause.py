"""Session 44: cli.main's start (the parser, the profile, output and reader modules, numpy
through them) runs with the garbage collector paused; process ends the pause as it freezes
the pipeline's modules (_modules_frozen), and every other way out of main -- another
command, a parse error, an empty command line, an exception -- turns the collector back on.
Each case in a fresh process (the collector's state is the process's): the collector off
during the start, on while the command runs (process: after its freeze), on after main;
and process writes the same bytes as with the pause switched off."""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLE = os.path.join(ROOT, "sample_gcode", "prusa_mk3s_rectilinear.gcode")

RUN = r"""
import contextlib, gc, io, json, sys
from gcode_opt import cli
argv, mode = json.loads(sys.argv[1]), sys.argv[2]
seen = {}
if mode == "off":                        # the code before: no pause
    cli._gc_pause = lambda: None
real_parser = cli.build_parser

def parser(only_process=False):
    seen["start"] = gc.isenabled()
    return real_parser(only_process)
cli.build_parser = parser
real_frozen = cli._modules_frozen

def frozen(name):
    t = real_frozen(name)
    seen["frozen"] = [gc.isenabled(), gc.get_freeze_count() > 0]
    return t
cli._modules_frozen = frozen
for name in ("cmd_profiles", "cmd_simulate"):
    real = getattr(cli, name)

    def wrap(a, real=real):
        seen["command"] = gc.isenabled()
        return real(a)
    setattr(cli, name, wrap)
code = None
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        code = cli.main(argv)
    except SystemExit as e:
        code = e.code
seen["after"] = [gc.isenabled(), gc.get_freeze_count()]
print(json.dumps([code, seen]))
"""


def _run(argv, mode="on"):
    env = dict(os.environ, PYTHONPATH=ROOT)
    out = subprocess.run([sys.executable, "-c", RUN, json.dumps(argv), mode], cwd=ROOT, env=env,
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out.splitlines()[-1])


def test_process_start_paused_then_frozen(tmp_path):
    out = str(tmp_path / "on.gcode")
    code, seen = _run(["process", SAMPLE, "-o", out, "-q"])
    assert code == 0 and seen["start"] is False and seen["frozen"] == [True, True]
    assert seen["after"] == [True, 0]
    code2, seen2 = _run(["process", SAMPLE, "-o", str(tmp_path / "off.gcode"), "-q"], "off")
    assert code2 == 0 and seen2["start"] is True
    assert open(out, "rb").read() == open(tmp_path / "off.gcode", "rb").read()


def test_every_other_way_out_turns_it_back_on(tmp_path):
    for argv in (["profiles"], ["simulate", str(tmp_path / "missing.gcode")], ["process", "--segments", "0", "x"],
                 [], ["process", str(tmp_path / "missing.gcode"), "-q"], ["nonsense"]):
        code, seen = _run(argv)
        assert seen["start"] is False, argv
        assert seen.get("command", True) is True, (argv, seen)
        assert seen["after"] == [True, 0], (argv, seen)
