"""The first pass's candidate tables wait for a re-plan in a temporary file and its
segment cache is let go before the rewrite (schedule.set_aside_for_rewrite): the tables
read back bit for bit, in their layout, and a command whose budget re-plans writes the
same bytes and figures as with both held in memory (the code this replaced)."""
import json
import os

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.plan import T_RATIOS, Candidates, SpilledCandidates
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _same_array(a, b):
    assert a.dtype == b.dtype and a.shape == b.shape
    assert a.flags.c_contiguous == b.flags.c_contiguous and a.flags.f_contiguous == b.flags.f_contiguous
    assert a.tobytes(order="A") == b.tobytes(order="A")


def _same_tables(a, b):
    assert type(b) is Candidates and a.k == b.k and a.T_orig is b.T_orig
    for name in Candidates.SPILLED:
        _same_array(getattr(a, name), getattr(b, name))
    for x, y in zip(a, b):            # the dense tables they stand for
        assert x.tobytes() == y.tobytes()


def _tables(rng, n, k, vals_order):
    """Candidates over n strokes and k columns, with NaN, inf, -0.0 and huge values
    among the entries and vals in vals_order."""
    mask = rng.random((n, k)) < 0.3
    m = int(mask.sum())
    vals = rng.standard_normal((4, m)) * 10.0 ** rng.integers(-300, 300, (4, m))
    if m:
        vals.flat[rng.integers(0, vals.size, 3)] = [np.nan, -np.inf, -0.0]
    vals = np.asarray(vals, order=vals_order)
    return Candidates(mask, vals, rng.random(n) < 0.5, rng.random(n))


@pytest.mark.parametrize("seed,n,order", [(0, 50, "C"), (1, 1, "C"), (2, 300, "F"), (3, 0, "C"), (4, 7, "F")])
def test_spill_reads_back_the_same_tables(tmp_path, seed, n, order):
    cands = _tables(np.random.default_rng(seed), n, len(T_RATIOS), order)
    spilled = cands.spill(str(tmp_path))
    assert type(spilled) is SpilledCandidates
    assert os.listdir(tmp_path) == []           # (an unnamed file: nothing left behind)
    _same_tables(cands, spilled.load())
    assert spilled.fh is None                   # (read once; the file closed)


def test_spill_of_planned_tables(tmp_path):
    """The tables plan_strokes made for a sample (lines sharing entries, curves, chains)."""
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, "prusa_gyroid.gcode"), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    cands = pin.cached[0]
    assert cands.vals.shape[1] > 1000
    _same_tables(cands, cands.spill(str(tmp_path)).load())


def test_spill_declines_what_it_cannot_write(tmp_path):
    cands = _tables(np.random.default_rng(5), 20, len(T_RATIOS), "C")
    assert cands.spill(str(tmp_path / "no such folder")) is None
    cands.vals = np.asfortranarray(np.tile(cands.vals, 2))[:, ::2]      # (neither C nor F contiguous)
    assert cands.spill(str(tmp_path)) is None


def _process(path, out, prof):
    opts = pipeline.Options()
    s = pipeline.process(path, str(out), load_profile(prof), opts)
    s = {k: v for k, v in s.items() if k not in ("timing_s", "input", "output") and "elapsed" not in k}
    return out.read_bytes(), json.dumps(s, sort_keys=True, default=str)


def _held(pin, folder, last):
    """The code set_aside_for_rewrite replaced: the tables and the cache stay held."""


@pytest.mark.parametrize("name,prof", [("edge/long_end_segment_curve.gcode", "prusa-mk3s"),
                                       ("prusa_benchy_like.gcode", "prusa-mk3s"),
                                       ("prusa_gyroid_fullspeed.gcode", "bambu-x1c")])
def test_replan_writes_the_same_as_with_the_tables_held(tmp_path, monkeypatch, name, prof):
    loads, seen = [], []
    load, set_aside = SpilledCandidates.load, schedule.set_aside_for_rewrite

    def counted_load(self):
        loads.append(self)
        return load(self)

    def watched(pin, folder, last):
        set_aside(pin, folder, last)
        seen.append((type(pin.cached[0]), pin.seg_cache))
    monkeypatch.setattr(SpilledCandidates, "load", counted_load)
    monkeypatch.setattr(pipeline, "set_aside_for_rewrite", watched)
    got = _process(os.path.join(SAMPLES, name), tmp_path / "a.gcode", prof)
    # the case re-plans (a second pass read the tables back), and neither pass held them
    assert len(loads) == 1 and seen == [(SpilledCandidates, None), (type(None), None)]
    assert json.loads(got[1])["rewrite_passes"] == 2
    monkeypatch.setattr(pipeline, "set_aside_for_rewrite", _held)
    ref = _process(os.path.join(SAMPLES, name), tmp_path / "b.gcode", prof)
    assert got[0] == ref[0]
    assert got[1] == ref[1]
    assert len(loads) == 1
