"""benchmarks/mem_breakdown.py: every phase reported, on a real sample, and its count of the
strokes' memory agrees with what tracemalloc saw the stroke-making code allocate."""
import os
import tracemalloc

import gcode_opt.pipeline as pl
import gcode_opt.schedule as sch
from bench_modules import load_bench

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")


def _load():
    return load_bench("mem_breakdown")


def _phases(mod):
    return list(mod.PHASES)


def test_phases_and_strokes_on_a_sample(capsys):
    mod = _load()
    before = {name: getattr(pl if m == "pipeline" else sch, name) for m, name in _phases(mod)}
    assert not tracemalloc.is_tracing()
    rows = mod.main([os.path.join(ROOT, "sample_gcode", "prusa_klipper.gcode"), "--profile", "voron24",
                     "--top", "40"])
    out = capsys.readouterr().out
    assert [r[0] for r in rows] == [name for _m, name in mod.PHASES]
    # the process is left as it was: tracing off (a later tracemalloc test measured the whole
    # suite's allocations once), the wrapped functions the modules' own again
    assert not tracemalloc.is_tracing()
    assert all(getattr(pl if m == "pipeline" else sch, name) is before[name] for m, name in _phases(mod))
    for name, cur, peak, rss, maxrss, files in rows:
        assert 0 < cur <= peak and rss > 0 and maxrss > 0, name
        assert files and all(mb >= 0 for _f, mb in files), name
    # the strokes, counted object by object, against tracemalloc's blocks allocated where
    # strokes are made (strokes.py; pipeline.py sets their end speeds and sums) at analyse
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("strokes:"))
    counted_mb = float(line.split(",")[1].split()[0])
    files = dict(rows[0][5])
    traced_mb = files.get("strokes.py", 0.0) + files.get("pipeline.py", 0.0)
    assert counted_mb > 0.1
    assert 0.5 * traced_mb < counted_mb < 1.5 * traced_mb, (counted_mb, traced_mb)
