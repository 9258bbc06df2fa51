"""The chain core's chain_finish (chains._finish_core: _finish_stacked_dt's whole numeric
work for a batch of rows in one C call) gives the numpy code's bits: on real batches
gathered while planning real files under classic jerk (prusa-mk3s, with and without its
planner buffer), Klipper's square-corner velocity (voron24, with and without a
buffer; the Klipper sample's own profile) and Marlin's junction deviation (ender3, with
and without a buffer), on random perturbations of them (stops,
cruises, short and long durations), for the acceleration and feed rows (predict False,
_replay's call) and the predicted figures; the numpy path is the reference (a verbatim
copy of the code before the core, kept here) and the fallback (no core, a stale core, an
input the core declines)."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.detect import auto_profile
from gcode_opt.laws import chain as chain_law
from gcode_opt.pipeline import Options, process
from gcode_opt.plan import SPEED_TOL_R
from gcode_opt.profile import load_profile
from gcode_opt.segments import hold_cruise_accels_rows

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
CORE = chain_law.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "chain_finish"), reason="no chain core")


def _ref_finish_stacked_dt(sts, gs, own, vk, tk, rules, profile, predict=True):
    """chains._finish_stacked_dt at d3559db (before the core), verbatim but for the names."""
    n = gs[0].d.size
    R = vk.shape[0]
    d = np.stack([g.d for g in gs])[own]
    a_top = np.array([chains._a_top(st) for st in sts], float)[own]
    acc, feed = chains.shape_segments(d.ravel(), np.maximum(tk, 1e-12).ravel(), vk[:, :-1].ravel(),
                                      vk[:, 1:].ravel(), np.repeat(a_top, n), trapezoid=rules.junction != "jerk")
    acc, feed = acc.reshape(R, n), feed.reshape(R, n)
    fits = np.all(acc <= (a_top * (1 + SPEED_TOL_R))[:, None], axis=1)
    acc = np.minimum(acc, a_top[:, None])
    step_v = np.inf
    if rules.junction == "jerk":
        step_v = (curves.JERK_F_STEP_R * np.array([min(st.lim.jerk_x, st.lim.jerk_y) for st in sts], float))[own]
        if profile.block_buffer > 0:       # _junction_accels under classic jerk: the lookahead floor
            window = chains._windows(gs, profile)[own]
            acc = np.maximum(acc, np.minimum(1.1 * feed ** 2 / (2.0 * window), a_top[:, None]))
    else:       # row by row: each row's junction accelerations from its own feeds as shaped
        for r in range(R):
            c = own[r]
            acc[r] = chains._junction_accels(sts[c], gs[c], vk[r], acc[r], rules, profile, feed[r])
    acc = hold_cruise_accels_rows(acc, a_top)
    feed = chains._tent_rows(feed, np.array([st.v_feed for st in sts], float)[own], step_v, core=False)
    if not predict:                  # (the caller has the figures: _replay)
        return acc, feed, None, None, fits
    t_pred, a2_pred = chains._predict_group(sts, gs, own, d, acc, feed, profile)
    return acc, feed, t_pred, a2_pred, fits


def _bits(x):
    return None if x is None else (x.shape, np.ascontiguousarray(x).view(np.uint8).tobytes())


def _same(got, want):
    return len(got) == len(want) and all(_bits(a) == _bits(b) for a, b in zip(got, want))


CASES = {   # name: (sample, profile (None: the file's), planner buffer (None: the profile's))
    "mk3s": ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s", None),
    "mk3s_nobuf": ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s", 0),
    "voron": ("prusa_gyroid_fullspeed.gcode", "voron24", None),
    "voron_buf": ("prusa_gyroid_fullspeed.gcode", "voron24", 16),
    "klipper_auto": ("prusa_gyroid_fullspeed_klipper.gcode", None, None),
    "ender3": ("prusa_gyroid_fullspeed.gcode", "ender3", None),          # Marlin's junction deviation
    "ender3_buf": ("prusa_gyroid_fullspeed.gcode", "ender3", 16),
    "ender3_tight": ("prusa_gyroid_fullspeed.gcode", "ender3", None),    # (a small deviation: the law binds)
}
TIGHT_JD = {"ender3_tight": 0.0005}     # junction_deviation_d of a case (else the profile's)
_BATCHES = {}


def _batches(tmp_path_factory, name, lines=5000, keep=24):
    """The first `keep` batches _finish_stacked_dt gets while a head of the sample is processed."""
    if name in _BATCHES:
        return _BATCHES[name]
    sample, pname, buf = CASES[name]
    src = SAMPLES / sample
    d = tmp_path_factory.mktemp("chainfin")
    head = d / sample
    with open(src) as fh:
        head.write_text("".join(fh.readlines()[:lines]))
    prof = auto_profile(str(src)).profile if pname is None else load_profile(pname)
    if buf is not None:
        prof = dataclasses.replace(prof, block_buffer=buf)
    if name in TIGHT_JD:
        prof = dataclasses.replace(prof, junction_deviation_d=TIGHT_JD[name])
    got = []
    orig = chains._finish_stacked_dt

    def spy(sts, gs, own, vk, tk, rules, profile, predict=True):
        if len(got) < keep:
            got.append((list(sts), list(gs), np.array(own), np.array(vk), np.array(tk), rules, profile, predict))
        return orig(sts, gs, own, vk, tk, rules, profile, predict)

    chains._finish_stacked_dt = spy
    orig_r, chains._finish_ragged = chains._finish_ragged, lambda *a, **k: None    # (s52: every batch here)
    try:
        process(str(head), str(d / "out.gcode"), prof, Options())
    finally:
        chains._finish_stacked_dt, chains._finish_ragged = orig, orig_r
    assert got, name
    _BATCHES[name] = got
    return got


def _numpy(b):
    """chains._finish_stacked_dt's numpy path (the core's fallback) on batch b."""
    save = chains._finish_core
    chains._finish_core = lambda *a, **k: None
    try:
        return chains._finish_stacked_dt(*b)
    finally:
        chains._finish_core = save


@needs_core
@pytest.mark.parametrize("name", list(CASES))
def test_core_equals_numpy_on_real_batches(tmp_path_factory, name):
    bs = _batches(tmp_path_factory, name)
    junction = bs[0][6].junction
    assert junction in chains.GROUP_JUNCTIONS
    assert any(b[7] for b in bs)
    rows = 0
    for b in bs:
        got = chains._finish_core(*b)
        assert got is not None                     # the core takes every real batch
        want = _ref_finish_stacked_dt(*b)
        assert _same(got, want)
        assert _same(_numpy(b), want)              # the fallback is the reference too
        assert _same(chains._finish_stacked_dt(*b), want)
        nb = b[:7] + (False,)                      # _replay's call: accelerations and feeds
        assert _same(chains._finish_core(*nb), _ref_finish_stacked_dt(*nb))
        rows += b[3].shape[0]
    assert rows >= 50


def _perturbed(b, rng):
    sts, gs, own, vk, tk, rules, prof, predict = b
    R, n1 = vk.shape
    vk = vk * rng.uniform(0.3, 1.6, vk.shape)
    tk = tk * rng.uniform(0.5, 2.0, tk.shape)
    z = rng.random(vk.shape) < 0.05                # stops at some knots
    vk[z] = 0.0
    flat = rng.random(R) < 0.2                     # rows of one speed: ramps of 0 (cruises)
    vk[flat] = vk[flat, :1]
    tk[rng.random(tk.shape) < 0.02] = 1e-14        # near-zero durations
    tk[rng.random(tk.shape) < 0.02] *= 1e3         # very long ones
    return (sts, gs, own, vk, tk, rules, prof, predict)


@needs_core
@pytest.mark.parametrize("name", list(CASES))
def test_core_equals_numpy_on_perturbed_batches(tmp_path_factory, name):
    rng = np.random.default_rng(21)
    declined = 0
    for b in _batches(tmp_path_factory, name)[:12]:
        for _ in range(3):
            p = _perturbed(b, rng)
            got = chains._finish_core(*p)
            want = _ref_finish_stacked_dt(*p)
            if got is None:                        # the core declines (a jerk tent input <= 0)
                declined += 1
                assert _same(chains._finish_stacked_dt(*p), want)
                continue
            assert _same(got, want)
    assert declined < 30


@needs_core
def test_core_declines_non_finite_and_falls_back(tmp_path_factory):
    for name in ("mk3s", "voron"):
        b = _batches(tmp_path_factory, name)[0]
        sts, gs, own, vk, tk, rules, prof, predict = b
        for arr, val in ((vk, np.nan), (tk, np.inf)):
            x = arr.copy()
            x[0, 1] = val
            p = (sts, gs, own, x if arr is vk else vk, x if arr is tk else tk, rules, prof, predict)
            assert chains._finish_core(*p) is None
            assert _same(chains._finish_stacked_dt(*p), _ref_finish_stacked_dt(*p))


def test_no_core_or_stale_core_falls_back(tmp_path_factory):
    b = _batches(tmp_path_factory, "voron")[0]
    assert chains._finish_core(*b, core=False) is None

    class Stale:                                   # an older build: no chain_finish
        pass
    assert chains._finish_core(*b, core=Stale()) is None
    save = chain_law.CORE_MOD
    chain_law.CORE_MOD = None                      # as GCODE_OPT_PURE_PYTHON=1
    try:
        got = chains._finish_stacked_dt(*b)
    finally:
        chain_law.CORE_MOD = save
    assert _same(got, _ref_finish_stacked_dt(*b))


def test_end_turn_products_are_dot2():
    """_finish_core makes predict_chains' end turns curves.dot2(prev_u, u[0]) as the two
    products and their sum over all chains at once: the same bits as dot2 row by row, and
    as the exactly rounded products added (no fused multiply-add anywhere: np.dot of two
    2-vectors fuses under OpenBLAS 0.3.31, so the product does not use it)."""
    from fractions import Fraction
    rng = np.random.default_rng(8)
    a = rng.normal(size=(5000, 2))
    b = rng.normal(size=(5000, 2))
    a /= np.linalg.norm(a, axis=1)[:, None]
    b /= np.linalg.norm(b, axis=1)[:, None]
    want = np.array([curves.dot2(x, y) for x, y in zip(a, b)])
    got = a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
    for x, y, w in zip(a[:200], b[:200], want[:200]):
        p = float(Fraction(x[0]) * Fraction(y[0])) + float(Fraction(x[1]) * Fraction(y[1]))
        assert p == w
