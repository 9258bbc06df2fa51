"""cli._modules_frozen: the pipeline's modules load with the garbage collector off and stay
frozen (out of its view) until the pipeline starts, which then freezes its own objects as
before; the output is the same bytes as with a plain import (each run in a fresh process:
the modules load once a process)."""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

FRESH = r"""
import gc, sys
from gcode_opt import cli
assert "gcode_opt.pipeline" not in sys.modules
thaw = cli._modules_frozen("gcode_opt.pipeline")
print(json.dumps(["gcode_opt.pipeline" in sys.modules, gc.isenabled(), gc.get_freeze_count() > 0]))
thaw()
after = gc.get_freeze_count()
thaw()                                   # a second call does nothing
print(json.dumps([after, gc.get_freeze_count(), gc.isenabled()]))
"""

PROCESS = r"""
import gc, importlib, sys
from gcode_opt import cli
plain = sys.argv[1] == "plain"
if plain:                                # the code it replaces: a plain import
    cli._modules_frozen = lambda name: (importlib.import_module(name), (lambda: None))[1]
import gcode_opt.pipeline as pl
seen = []
real = pl.process

def process(*a, **k):
    seen.append((gc.get_freeze_count(), gc.isenabled()))
    return real(*a, **k)
pl.process = process
code = cli.main(["process", sys.argv[2], "-o", sys.argv[3], "-q", "--json", sys.argv[3] + ".json"])
print(json.dumps([code, seen]))
"""


def _run(code, *args):
    env = dict(os.environ, PYTHONPATH=ROOT)
    out = subprocess.run([sys.executable, "-c", "import json\n" + code, *args], cwd=ROOT, env=env,
                         capture_output=True, text=True, check=True).stdout
    return [json.loads(line) for line in out.splitlines()]


def test_modules_load_frozen_and_thaw_once():
    (loaded, enabled, frozen), (after, again, enabled2) = _run(FRESH)
    assert loaded and enabled and frozen
    assert after == 0 and again == 0 and enabled2


def _strip_times(d):
    if isinstance(d, dict):
        return {k: _strip_times(v) for k, v in d.items() if k not in ("elapsed_s", "output", "timing_s")
                and not (isinstance(v, dict) and "analyse" in v)}
    if isinstance(d, list):
        return [_strip_times(v) for v in d]
    return d


def test_pipeline_starts_with_nothing_frozen_and_same_output(tmp_path):
    for name in ("prusa_klipper.gcode", "prusa_gyroid.gcode"):
        outs = {}
        for how in ("frozen", "plain"):
            dst = str(tmp_path / f"{how}-{name}")
            [(code, seen)] = _run(PROCESS, how, "sample_gcode/" + name, dst)
            assert code == 0
            # the pipeline freezes its own objects only where nothing is frozen: it must start thawed
            assert seen == [[0, True]]
            with open(dst, "rb") as fh, open(dst + ".json") as fj:
                outs[how] = (fh.read(), _strip_times(json.load(fj)))
        assert outs["frozen"][0] == outs["plain"][0]
        assert outs["frozen"][1] == outs["plain"][1]


def test_thawed_however_the_command_ends(tmp_path, capsys):
    """A command that fails before the pipeline starts (a missing or refused input) leaves
    nothing frozen (in-process callers: the tests, a slicer plugin)."""
    import gc

    from gcode_opt import cli
    bad = tmp_path / "bad.bgcode"
    bad.write_bytes(b"GCDE\x01\x00\x00\x00garbage")
    assert gc.get_freeze_count() == 0
    for src in (str(tmp_path / "missing.gcode"), str(bad)):
        code = cli.main(["process", src, "-o", str(tmp_path / "out.gcode"), "-q"])
        assert code != 0
        assert gc.get_freeze_count() == 0 and gc.isenabled()
    capsys.readouterr()
