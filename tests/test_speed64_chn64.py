"""s64 (chn): the chains' candidates and replays with fewer Python steps a chain, the same
numbers: _finish_ragged's flat inputs made in place (its answers = each batch finished
alone by _finish_stacked_dt), _flat_chains' inner arc lengths by runs (_inner_s_runs =
_inner_s), _caps_sizes' fromiter, the kept caps by a C-level map (_kept_caps = its
steps, _kept_caps_made), _all_laws; on real files' chains, both junction laws (the
windowed bytes at small windows: tests/test_speed63_chc_knots.py)."""
import os

import numpy as np
import pytest

from gcode_opt import chains, curves, pipeline, schedule
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")
CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_fullspeed_klipper.gcode", "voron24")]


class _Failed(BaseException):
    """An assertion inside the planning (not an Exception: isolate does not catch it)."""


def _raising(fn):
    def call(*a, **k):
        try:
            return fn(*a, **k)
        except AssertionError as e:
            raise _Failed("assertion in the planning: %s" % e) from e
    return call


def _plan(name, prof):
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.skipif(chains._chain_law.CORE_MOD is None, reason="the chain core is not built")
@pytest.mark.parametrize("name,prof", CASES)
def test_ragged_answers_are_each_batch_alone(name, prof, monkeypatch):
    seen = []
    real = chains._finish_ragged

    def check(batches, rules, profile, core=None, predict=True):
        got = real(batches, rules, profile, core, predict)
        if got is not None:
            assert len(got) == len(batches)
            for (sts, gs, own, vk, tk), g in zip(batches, got):
                want = chains._finish_stacked_dt(sts, gs, own, vk, tk, rules, profile, predict=predict)
                for a, b in zip(g, want):
                    if a is None or b is None:
                        assert a is None and (b is None or not predict)
                    else:
                        assert _same(a, b)
            seen.append(len(batches))
        return got

    monkeypatch.setattr(chains, "_finish_ragged", _raising(check))
    _plan(name, prof)
    assert seen and max(seen) > 1


@pytest.mark.parametrize("name,prof", CASES)
def test_flat_chain_helpers_are_their_references(name, prof, monkeypatch, tmp_path):
    """The list path's plan, then the windowed command (its chains' caps kept already:
    _kept_caps' map)."""
    seen = {"runs": 0, "caps": 0, "kept": 0}
    inner_runs, kept_caps, caps_sizes = chains._inner_s_runs, chains._kept_caps, chains._caps_sizes

    def runs(gs):
        got = inner_runs(gs)
        assert _same(got, chains._inner_s(gs))
        seen["runs"] += 1
        return got

    def caps(sts, gs, profile):
        all_kept = all(g.chain_caps is not None for g in gs)
        got = kept_caps(sts, gs, profile)
        want = chains._kept_caps_made(sts, gs, profile)      # (changes no geometry once all are kept)
        assert len(got) == len(want)
        assert all(_same(chains._caps_array(a), chains._caps_array(b)) for a, b in zip(got, want))
        if all_kept:                                        # (the geometries' own objects)
            assert all(a is g.chain_caps for a, g in zip(got, gs))
        seen["caps"] += 1
        seen["kept"] += all_kept
        return got

    def sizes(caps):
        got = caps_sizes(caps)
        want = np.array([len(c) >> 3 if type(c) is bytes else c.size for c in caps], int)
        assert _same(got, want)
        return got

    monkeypatch.setattr(chains, "_inner_s_runs", _raising(runs))
    monkeypatch.setattr(chains, "_kept_caps", _raising(caps))
    monkeypatch.setattr(chains, "_caps_sizes", _raising(sizes))
    _plan(name, prof)
    assert seen["runs"] and seen["caps"]
    from gcode_opt import cli
    monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
    cli.main(["process", os.path.join(SAMPLES, name), "-o", str(tmp_path / "w.gcode"), "-q", "--profile", prof])
    # (classic jerk's windowed geometries keep their chains' caps: the map's case; the
    # voron's made again a call)
    assert seen["kept"] or prof != "prusa-mk3s"


def test_inner_s_runs_declines_to_inner_s():
    """Geometries without segments (a count of 0): _inner_s itself (its own per-chain path)."""

    class G:
        def __init__(self, d):
            self.d = np.asarray(d, float)
            self.s_v = np.concatenate([[0.0], np.cumsum(self.d)])

    gs = [G([1.0, 2.0, 3.0]), G([]), G([0.5, 0.25])]
    orig = curves.seg_counts
    try:
        curves.seg_counts = lambda gs: [g.d.size for g in gs]
        assert _same(chains._inner_s_runs(gs), chains._inner_s(gs))
    finally:
        curves.seg_counts = orig


def test_all_laws():
    class K:
        def __init__(self, n):
            self.base = (None,) * n

    assert chains._all_laws([])
    assert chains._all_laws([(None, K(8), 0), (None, K(8), 1)])
    assert not chains._all_laws([(None, K(8), 0), (None, K(4), 1)])
    # an item without a base after one not of 8: the generator's answer (it stops there)
    assert not chains._all_laws([(None, K(4), 0), (None, None, 1)])
