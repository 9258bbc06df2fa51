"""Round 31 (geoms): the curves' geometry and the chains' classification with less work.

* _parts_block's kernel by kern_pack / kern_unpack (laws/_curvecore.c): the arguments
  np.exp does not take to +0.0 made and packed in one pass, then put back with +0.0
  around each row's run: against kern_args + _exp_inplace (the code it replaces, kept
  below) bit for bit, on real blocks and on rows it must decline (NaN, unsorted).
* build_geoms returns the blocks it made and chains.classify tests them as they are (no
  regrouping by block, no row index array); the limits per stroke (_lims_which), the
  neighbours' directions and the per-block lists read with map/attrgetter: chain marks,
  chains' caps and every geometry field against b219ac3's classify kept verbatim below.
"""
import os

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.chains import CHAIN_CAP_MARGIN, ChainMemo
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode")
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_gyroid.gcode")
CORE = circle.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "kern_pack"), reason="no compiled curve core")


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _curves_of(path, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(path, prof, Options())
    return prof, [st for st in strokes if st.kind == K_CURVE]


# ---------------------------------------------------------------- the kernel
def _old_kernel(s_v, smooth_d, n):
    """b219ac3's kernel: kern_args, then _exp_inplace (split, np.exp, merge)."""
    kern = np.empty((s_v.shape[0], n + 1, n - 1))
    CORE.kern_args(s_v, smooth_d, s_v.shape[0], n + 1, kern)
    curves._exp_inplace(kern)
    return kern


def _kernel_inputs(sts):
    """(s_v, smooth_d, n) of every block _part_blocks makes of the strokes sts."""
    got = []
    orig = curves._kern_packed

    def spy(s_v, smooth_d, n):
        got.append((s_v.copy(), smooth_d.copy(), n))
        return orig(s_v, smooth_d, n)
    curves._kern_packed = spy
    try:
        for _ in curves._part_blocks(sts):
            pass
    finally:
        curves._kern_packed = orig
    return got


@needs_core
@pytest.mark.parametrize("path", [os.path.join(S, "prusa_gyroid.gcode"), PLATE])
def test_packed_kernel_is_the_split_one(path):
    if not os.path.exists(path):
        pytest.skip("corpus plate not downloaded")
    if not curves._exp_zero_ok():
        pytest.skip("np.exp does not give +0.0 below EXP_ZERO_BELOW here: the kernel is not split")
    _, sts = _curves_of(path, "prusa-mk3s")
    if path == PLATE:
        sts = sts[::4]
    blocks = _kernel_inputs(sts)
    assert len(blocks) > 5
    zeros = 0
    for s_v, sd, n in blocks:
        with np.errstate(all="ignore"):
            new = curves._kern_packed(s_v, sd, n)
            old = _old_kernel(s_v, sd, n)
        assert new is not None and _bits(new, old)
        zeros += int((old == 0.0).sum())
    assert zeros > 0            # some arguments were below EXP_ZERO_BELOW


@needs_core
def test_packed_kernel_declines_what_is_not_one_run():
    """Rows whose kept arguments are not one run (s_v unsorted) or hold NaN around
    dropped ones: kern_pack says -1 and _parts_block takes the old path; sorted rows with
    NaN lengths, huge and tiny widths, every argument dropped: the old kernel's bits."""
    if not curves._exp_zero_ok():
        pytest.skip("the kernel is not split here")
    rng = np.random.default_rng(31)
    n = 12
    s_v = np.concatenate([np.zeros((6, 1)), np.cumsum(rng.uniform(0.05, 0.4, (6, n)), axis=1)], axis=1)
    sd = np.array([0.2, 0.3, 1e-3, 1e3, 0.25, 0.2])
    with np.errstate(all="ignore"):
        got = curves._kern_packed(s_v, sd, n)
        assert got is not None and _bits(got, _old_kernel(s_v, sd, n))
        assert (got[2] == 0.0).any() and (got[3] > 0.0).all()
        bad = s_v.copy()
        bad[1, 7] = bad[1, 2]                            # a vertex again further on: two runs
        assert curves._kern_packed(bad, sd * 1e-3, n) is None
        nan = s_v.copy()
        nan[4, 5] = np.nan                               # NaN arguments (kept) in a dropped stretch
        r = curves._kern_packed(nan, sd * 1e-3, n)
        assert r is None or _bits(r, _old_kernel(nan, sd * 1e-3, n))
        nsd = sd.copy()
        nsd[0] = np.nan                                  # a NaN width: every argument NaN, one run
        assert _bits(curves._kern_packed(s_v, nsd, n), _old_kernel(s_v, nsd, n))
        one = s_v[:, :4].copy()                          # n = 3: one interior vertex
        assert _bits(curves._kern_packed(one, sd, 3), _old_kernel(one, sd, 3))
        # rows kern_pack knows are one run (sorted, finite) next to rows it checks: repeated
        # vertices, overflowing differences, an infinite or zero width, an infinite vertex
        odd = s_v.copy()
        odd[0, 4:7] = odd[0, 4]                          # repeated vertices (still in order)
        odd[1] = np.linspace(-1.5e308, 1.5e308, n + 1)    # differences overflow to inf
        odd[2, -1] = np.inf
        odd[3, 0] = -np.inf
        osd = sd.copy()
        osd[4], osd[5] = np.inf, 0.0
        for w in (osd, osd * 1e-3, osd * 1e3):
            r = curves._kern_packed(odd, w, n)
            assert r is None or _bits(r, _old_kernel(odd, w, n))
        assert _bits(curves._kern_packed(odd[:2], sd[:2], n), _old_kernel(odd[:2], sd[:2], n))


@needs_core
def test_parts_block_same_with_and_without_the_packed_kernel(monkeypatch):
    _, sts = _curves_of(os.path.join(S, "prusa_gyroid.gcode"), "voron24")
    new = [b for _, b in curves._part_blocks(sts)]
    monkeypatch.setattr(curves, "_KERN_PACK", None)
    old = [b for _, b in curves._part_blocks(sts)]
    assert len(new) == len(old) > 3
    for a, b in zip(new, old):
        for x, y in zip(a, b):
            assert _bits(x, y)


# ---------------------------------------------------------------- classify
def Rclassify(strokes, rows, profile):
    """b219ac3's chains.classify, verbatim (names prefixed R)."""
    sts = [strokes[i] for i in rows if strokes[i].kind == K_CURVE]
    curves.build_geoms(sts, profile, jerk1=True)
    jerk = profile.junction == "jerk"
    by_blk = {}
    for q, st in enumerate(sts):
        b = getattr(curves.geom(st, profile), "_b", None)
        by_blk.setdefault(id(b), (b, []))[1].append(q)
    for b, qs in by_blk.values():
        if type(b) is not curves._Blk or not R_classify_block(b, [sts[q] for q in qs], jerk):
            for q in qs:
                chains._classify_one(sts[q], profile, jerk)
    if jerk:
        curves.drop_jerk1(sts)


def R_classify_block(b, sts, jerk):
    if not (b.cap_min and isinstance(b.cap, np.ndarray) and b.caps.ndim == 2 and b.caps.shape[1] > 0):
        return False
    if jerk and any(st.curv._j1 is not curves._FROM_BLOCK for st in sts):
        return False
    ks = np.array([st.curv._k for st in sts], np.int64)
    feed = np.array([st.v_feed for st in sts], float)
    hit = np.flatnonzero(b.cap[ks] < feed).tolist()
    if not hit:
        return True
    caps1 = None
    if jerk and b.caps_jerk1 is not None:
        caps1 = CHAIN_CAP_MARGIN * b.caps_jerk1[ks[hit]]
    for i, q in enumerate(hit):
        st = sts[q]
        st.chain_T = ChainMemo()
        g = st.curv
        if caps1 is not None and g.chain_caps is None:
            g.chain_caps = caps1[i].copy()
            g.caps_jerk1 = None
    return True


def _state(sts, prof):
    """What classify leaves: each stroke's mark, its chain caps (bits), the caps at the
    whole jerk left, and its geometry's fields a curve reads (cap, κ_eff, cos_end, d, caps)."""
    out = []
    for st in sts:
        g = st.curv
        c1 = g.caps_jerk1
        out.append((st.chain_T is not None, None if g.chain_caps is None else chains._caps_array(g.chain_caps).tobytes(),
                    None if c1 is None else np.asarray(c1).tobytes(), np.float64(g.cap).tobytes(),
                    np.float64(g.kappa_eff).tobytes(), repr(g.cos_end), g.d.tobytes(),
                    np.asarray(g.caps).tobytes(), chains.vertex_caps(st, prof).tobytes()))
    return out


def _classified(fn, strokes, rows, prof, pre=()):
    for st in strokes:
        st.curv, st.chain_T = None, None
    if pre:                                   # some geometries made before (another batch)
        curves.build_geoms(list(pre), prof, jerk1=False)
    fn(strokes, rows, prof)
    return _state([strokes[i] for i in rows if strokes[i].kind == K_CURVE], prof)


CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
         ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"), ("prusa_gyroid_fullspeed.gcode", "prusa-mk4"),
         ("prusa_concentric.gcode", "ender3")]


@pytest.mark.parametrize("name,profile", CASES)
def test_classify_as_b219ac3(name, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(os.path.join(S, name), prof, Options())
    rows = list(range(len(strokes)))
    got = _classified(chains.classify, strokes, rows, prof)
    want = _classified(Rclassify, strokes, rows, prof)
    assert got == want
    assert any(x[0] for x in got) or profile != "prusa-mk3s"
    # some geometries made before classify (not rows of its blocks): the slow path too
    cur = [st for st in strokes if st.kind == K_CURVE]
    pre = cur[::3]
    assert _classified(chains.classify, strokes, rows, prof, pre) == _classified(Rclassify, strokes, rows, prof, pre)


def test_classify_with_degenerate_strokes_as_b219ac3():
    """Strokes CurveGeom's own path takes (one segment, tiny, past _GEOM_MAX_PTS) among
    the batched ones, and strokes with several limits objects."""
    import copy
    from gcode_opt.strokes import Points
    rng = np.random.default_rng(7)
    for profile in ("prusa-mk3s", "voron24"):
        prof = load_profile(profile)
        strokes, _ = analyse(os.path.join(S, "prusa_gyroid.gcode"), prof, Options())
        cur = [st for st in strokes if st.kind == K_CURVE][:80]
        for k, st in enumerate(cur):
            pts = np.array(st.pts, float)
            if k % 13 == 3:
                pts = pts[:2]
            elif k % 13 == 4:
                pts = pts * 1e-4
            elif k % 13 == 6:
                pts = np.vstack([pts, pts[-1] + np.cumsum(rng.uniform(0.1, 0.3, (600, 2)), axis=0)])
            st.pts = Points(pts.ravel().tolist())
            if k % 4 == 1:                          # another limits object, equal numbers
                st.lim = copy.copy(st.lim)
            if k % 7 == 2:
                st.prev_u = None
        rows = list(range(len(cur)))
        assert _classified(chains.classify, cur, rows, prof) == _classified(Rclassify, cur, rows, prof)


def test_lims_which_as_setdefault():
    class L:
        pass
    a, b, c = L(), L(), L()

    class St:
        def __init__(self, lim):
            self.lim = lim
    for seq in ([a], [a, a, a], [b, a, b, c, a], [c, c, b]):
        sts = [St(x) for x in seq]
        seen = {}
        which = [seen.setdefault(id(st.lim), (len(seen), st.lim))[0] for st in sts]
        lims = [lim for _, lim in seen.values()]
        got_lims, got_which = curves._lims_which(sts)
        assert got_lims == lims and got_which.dtype == np.int32 and got_which.tolist() == which


# ---------------------------------------------------------------- adjust_plan_inputs
def Radjust_plan_inputs(pin, strokes, rows, profile, cap_peak=True):
    """b219ac3's curves.adjust_plan_inputs, verbatim (names prefixed R)."""
    mx, my = profile.moving_mass_x_kg, profile.moving_mass_y_kg
    rows = [int(i) for i in rows]
    gs = [curves.geom(strokes[i], profile) for i in rows]
    ux2 = np.array(curves._ux2_rows(gs), float)
    uy2 = 1.0 - ux2
    den = mx * ux2 + my * uy2
    if not len(rows) or (den == 0.0).any():
        for i, x in zip(rows, ux2.tolist()):
            y = 1.0 - x
            pin.mass_r[i] = (mx * mx * x + my * my * y) / (mx * x + my * y)
    else:
        pin.mass_r[rows] = (mx * mx * ux2 + my * my * uy2) / den
    sts = [strokes[i] for i in rows]
    pin.a_cap[rows] = [min(st.accel, st.lim.ax_max, st.lim.ay_max) for st in sts]
    if cap_peak and rows:
        vc = pin.v_cap[rows]
        cap = np.array([g.cap for g in gs], float)
        pin.v_cap[rows] = np.where(cap < vc, cap, vc)
        for g in gs:
            g.caps_jerk1 = None


def _pin_after(adjust, strokes, prof, tweak=None):
    from gcode_opt import schedule
    for st in strokes:
        st.curv, st.chain_T = None, None
    if tweak:
        tweak(strokes)
    kind = schedule.KINDS[K_CURVE]
    saved = (curves.adjust_plan_inputs, kind.adjust_inputs)
    curves.adjust_plan_inputs = kind.adjust_inputs = adjust      # (chains' calls it as curves')
    try:
        pin = schedule.plan_inputs(strokes, prof, Options())
    finally:
        curves.adjust_plan_inputs, kind.adjust_inputs = saved
    cur = [st for st in strokes if st.kind == K_CURVE]
    return ([np.asarray(a).tobytes() for a in (pin.mass_r, pin.a_cap, pin.v_cap)] + [list(pin.fault)],
            [st.curv.caps_jerk1 is None for st in cur])


@pytest.mark.parametrize("name,profile", CASES + [("prusa_concentric.gcode", "prusa-mk3s")])
def test_adjust_plan_inputs_as_b219ac3(name, profile):
    """Every plan input (masses, acceleration and speed caps) and the caps let go, as
    b219ac3's; curves and chains (chains.adjust_plan_inputs calls it with cap_peak=False)."""
    prof = load_profile(profile)
    strokes, _ = analyse(os.path.join(S, name), prof, Options())
    assert _pin_after(curves.adjust_plan_inputs, strokes, prof) == _pin_after(Radjust_plan_inputs, strokes, prof)


def test_adjust_plan_inputs_other_limits_and_geometries_as_b219ac3():
    """Several limits objects (and an int acceleration: the list of Python mins), and
    geometries of CurveGeom's own path (not rows of build_geoms' blocks)."""
    import copy
    prof = load_profile("voron24")
    strokes, _ = analyse(os.path.join(S, "prusa_gyroid.gcode"), prof, Options())
    cur = [st for st in strokes if st.kind == K_CURVE]

    def other_limits(sts):
        for k, st in enumerate(cur):
            if k % 3 == 1:
                st.lim = copy.copy(st.lim)
                st.lim.ax_max = st.lim.ax_max * (0.5 + 0.1 * (k % 7))
                st.accel = float(st.accel) * 0.9

    def own_path(sts):
        other_limits(sts)
        for st in cur[::5]:
            st.curv = curves.CurveGeom(st, prof)
        cur[7].accel = int(cur[7].accel)
    for tweak in (other_limits, own_path):
        lims = [(st.lim, st.accel) for st in cur]
        got = _pin_after(curves.adjust_plan_inputs, strokes, prof, tweak)
        for st, (lim, a) in zip(cur, lims):
            st.lim, st.accel = lim, a
        want = _pin_after(Radjust_plan_inputs, strokes, prof, tweak)
        for st, (lim, a) in zip(cur, lims):
            st.lim, st.accel = lim, a
        assert got == want


# ---------------------------------------------------------------- circle._row_lengths
def R_row_lengths(coef):
    """b219ac3's circle._row_lengths, verbatim."""
    nz = coef != 0
    return np.where(nz.any(axis=1), coef.shape[1] - np.argmax(nz[:, ::-1], axis=1), 1)


def test_row_lengths_as_b219ac3():
    """The compiled scan against numpy's four passes: zeros, -0.0 (a zero), NaN (not a
    zero), all-zero rows, one column, no rows, views that are not contiguous."""
    rng = np.random.default_rng(31)
    for _ in range(300):
        B, K = int(rng.integers(0, 40)), int(rng.integers(1, 30))
        c = rng.normal(size=(B, K))
        c[rng.random((B, K)) < 0.5] = 0.0
        c[rng.random((B, K)) < 0.05] = -0.0
        c[rng.random((B, K)) < 0.02] = np.nan
        c[:B // 4] = 0.0
        for x in (c, c[:, ::2], c[::3]):
            if x.shape[1]:
                got, want = circle._row_lengths(x), R_row_lengths(x)
                assert got.dtype == want.dtype and got.tolist() == want.tolist()
