"""What a process run of a file without arcs loads at its start (session 48): not the modules
only other commands, arc strokes or the exact curve law need, nor source that @dataclass or
typing.NamedTuple generate and compile, nor the patterns the compiled reader and rewrite make
unneeded.  Run with `python -X importtime` in a subprocess: the import log names the modules
the run imported (but one that importlib.import_module loads: cli loads the pipeline so),
sys.modules at the end names them all."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# not needed by `process` on a file without G2/G3 (a plate): imported where they are used
NOT_NEEDED = ("gcode_opt.arcs", "gcode_opt.laws.curve", "gcode_opt.laws.direct", "gcode_opt.report",
              "gcode_opt.verify", "gcode_opt.bgcode", "gcode_opt.bgcode_job", "scipy", "matplotlib", "json")

CHECK = """
import re, sys, types
sys.argv = ["gcode_opt", "process", {src!r}, "-o", {out!r}, "-q"]
from gcode_opt.cli import main
assert not main()
generated = []                      # functions compiled from generated source ("<string>")
for name, mod in list(sys.modules.items()):
    if not name.startswith("gcode_opt"):
        continue
    for obj in vars(mod).values():
        if isinstance(obj, type) and obj.__module__ == name:
            for fn in vars(obj).values():
                code = getattr(fn, "__code__", None)
                if code is not None and code.co_filename == "<string>":
                    generated.append(f"{{name}}.{{obj.__name__}}.{{fn.__name__}}")
from gcode_opt import emit, state, validate
pending = [n for n, v in (("state._fast_match", state._fast_match), ("state._fast_m204", state._fast_m204),
                          ("emit._MOVE_XYE", emit._MOVE_XYE), ("emit._MOVE_LINES", emit._MOVE_LINES),
                          ("validate.NUM", vars(validate)["NUM"]), ("validate.WORD", vars(validate)["WORD"]))
           if type(v) is re.Pattern or isinstance(getattr(v, "__self__", None), re.Pattern)]
print("MODULES", " ".join(sorted(sys.modules)))
print("GENERATED", generated)
print("COMPILED", pending)
"""


def _run(tmp_path, sample):
    src = str(ROOT / "sample_gcode" / sample)
    code = CHECK.format(src=src, out=str(tmp_path / "out.gcode"))
    got = subprocess.run([sys.executable, "-X", "importtime", "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert got.returncode == 0, got.stderr[-2000:]
    logged = {line.split("|")[-1].strip() for line in got.stderr.splitlines() if line.startswith("import time:")}
    out = got.stdout.splitlines()
    present = set(next(line for line in out if line.startswith("MODULES ")).split()[1:])
    assert "gcode_opt.schedule" in logged and "gcode_opt.pipeline" in present      # (both lists read)
    return logged | present, out


def test_a_process_run_without_arcs_imports_none_of_the_unneeded_modules(tmp_path):
    for sample in ("prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode"):
        imported, out = _run(tmp_path, sample)
        assert sorted(m for m in NOT_NEEDED if m in imported) == [], sample
        assert "GENERATED []" in out, out
        assert "COMPILED []" in out, out


def test_an_arc_stroke_imports_arcs_where_it_is_planned(tmp_path):
    imported, _ = _run(tmp_path, "prusa_gyroid_arcs.gcode")
    assert "gcode_opt.arcs" in imported
