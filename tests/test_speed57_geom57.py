"""The windowed run's curve geometry made once (geom_keep.GeomKeep, benchmarks/geom57.md):
the geometry plan_inputs made, written as it is made and given back to a window loaded
again, is the geometry build_geoms makes of that window (every field a consumer reads, bit
for bit: lengths, directions, κ, κ_eff, caps, cap, end turns, the chains' caps), given a
window at a time or rows of several windows; the windowed command then makes no curve
geometry after plan_inputs and writes the list path's bytes."""
import json
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains, curves, pipeline
from gcode_opt import features as feat
from gcode_opt.geom_keep import GeomKeep
from gcode_opt.plan_windows import plan_inputs_windowed
from gcode_opt.profile import load_profile
from gcode_opt.schedule import C_CHAIN, C_CURVE
from gcode_opt.stored_strokes import curve_geometry
from gcode_opt.stroke_store import StrokeStore

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
NAME = "prusa_gyroid_fullspeed.gcode"
WINDOW, PIN = 37, 100           # plan_inputs' calls cut windows (100 is no multiple of 37)


def _kept(tmp_path, prof_name):
    """(profile, store, its GeomKeep filled by plan_inputs_windowed, plan_kind codes)."""
    prof = load_profile(prof_name)
    path = str(SAMPLES / NAME)
    opts = pipeline.Options(features=feat.default_selection(path)[0])
    store = StrokeStore(folder=str(tmp_path))
    pipeline.analyse(path, prof, opts, store)
    keep = GeomKeep(WINDOW, prof, str(tmp_path))
    pin = plan_inputs_windowed(store, prof, opts, PIN, keep)
    return prof, store, keep, pin.plan_kind_codes


def _bits(x):
    a = np.asarray(x)
    return a.dtype.str, a.shape, a.tobytes()


def _fields(st, chain, prof):
    """Every field of st's geometry a consumer reads, as bits (the chains' caps too)."""
    g = st.curv
    ends = tuple(None if c is None else float(c).hex() for c in g.cos_end)
    got = [_bits(g.d), _bits(g.u), _bits(g.kappa_v), float(g.kappa_eff).hex(), float(g.cap).hex(), ends,
           _bits(g.caps), _bits(g.s_v), _bits(g.cos_turn)]
    if chain:
        got.append(_bits(chains.vertex_caps(st, prof)))
    return got


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])     # classic jerk; Klipper's (caps kept)
@pytest.mark.parametrize("kappa", [True, False])
def test_given_geometry_is_the_made_geometry(tmp_path, prof_name, kappa):
    prof, store, keep, codes = _kept(tmp_path, prof_name)
    made = curve_geometry(codes, prof)            # (no keep: build_geoms of the window, as before)
    ours = (codes == C_CURVE) | (codes == C_CHAIN)
    assert (codes == C_CHAIN).sum() > 10 and (codes == C_CURVE).sum() > 10
    for lo in range(0, len(store), WINDOW):
        given, want = store.load(lo, lo + WINDOW), store.load(lo, lo + WINDOW)
        keep.give(np.arange(lo, lo + len(given)), given, kappa=kappa)
        made(lo, want)
        for k in np.flatnonzero(ours[lo:lo + len(given)]).tolist():
            chain = codes[lo + k] == C_CHAIN
            assert given[k].curv is not None
            # (classic jerk: a chain's caps given as plan_inputs made them, not made again)
            assert not (chain and prof.junction == "jerk") or type(given[k].curv.chain_caps) is bytes
            assert _fields(given[k], chain, prof) == _fields(want[k], chain, prof), (lo + k)
    assert keep.given == ours.sum()               # every curve and chain given back


def test_rows_of_several_windows_given(tmp_path):
    """Rows asked across windows (a chain call's, schedule._chain_plans): each its own
    geometry, the blocks given of those rows alone."""
    prof, store, keep, codes = _kept(tmp_path, "prusa-mk3s")
    rows = np.flatnonzero((codes == C_CURVE) | (codes == C_CHAIN))[::3]
    assert np.unique(rows // WINDOW).size > 3
    given, want = store.take(rows), store.take(rows)
    keep.give(rows, given)
    curves.build_geoms(want, prof, jerk1=True)
    for r, a, b in zip(rows.tolist(), given, want):
        chain = codes[r] == C_CHAIN
        assert _fields(a, chain, prof) == _fields(b, chain, prof), r
    assert keep.given == rows.size
    blocks = {id(st.curv._b): st.curv._b for st in given}
    assert sum(b.d.shape[0] for b in blocks.values()) == rows.size      # (no row not asked made)


def test_no_file_no_geometry(tmp_path, monkeypatch):
    """Where no spill can be made, nothing is kept or given (the callers make it as before)."""
    from gcode_opt.spill_file import SpillFile
    monkeypatch.setattr(SpillFile, "open", staticmethod(lambda folder=None: None))
    prof, store, keep, codes = _kept(tmp_path, "prusa-mk3s")
    sts = store.load(0, WINDOW)
    keep.give(np.arange(len(sts)), sts)
    assert keep.recs == {} and all(st.curv is None for st in sts)


VOLATILE = ("timing_s", "elapsed_s", "output")


def _run(monkeypatch, tmp_path, prof, window=None):
    if window is None:
        monkeypatch.delenv("GCODE_OPT_WINDOWED", raising=False)
    else:
        monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
        monkeypatch.setenv("GCODE_OPT_WINDOW", str(window))
    out = tmp_path / f"out.{window}.gcode"
    s = pipeline.process(str(SAMPLES / NAME), str(out), load_profile(prof), pipeline.Options())
    return out.read_bytes(), json.loads(json.dumps({k: v for k, v in s.items() if k not in VOLATILE}, default=str))


@pytest.mark.parametrize("prof,window", [("prusa-mk3s", 37), ("voron24", 64)])
def test_windowed_command_makes_no_geometry_again(monkeypatch, tmp_path, prof, window):
    """The windowed command: every curve geometry after plan_inputs given back (build_geoms
    called by chains.classify alone), the list path's file and summary."""
    want = _run(monkeypatch, tmp_path, prof)
    calls = []
    build = curves.build_geoms

    def counted(strokes, *a, **k):
        import sys
        calls.append((sys._getframe(1).f_code.co_name, len([st for st in strokes if st.curv is None])))
        return build(strokes, *a, **k)
    monkeypatch.setattr(curves, "build_geoms", counted)
    given = []
    give = GeomKeep.give

    def counted_give(self, rows, sts, kappa=False):
        n = self.given
        give(self, rows, sts, kappa)
        given.append(self.given - n)
    monkeypatch.setattr(GeomKeep, "give", counted_give)
    got = _run(monkeypatch, tmp_path, prof, window)
    assert sum(given) > 0
    assert [c for c in calls if c[0] != "classify" and c[1]] == []
    assert got[0] == want[0]
    assert got[1] == want[1]

