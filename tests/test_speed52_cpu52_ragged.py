"""The chain core's chain_finish_ragged (chains._finish_ragged: the finishing of batches of
several segment counts in one C call) gives, batch by batch, the bits of the per-batch
calls it replaces (chains._finish_stacked_dt: the chain core's chain_finish, or the numpy
code where that declines): on real batches gathered while processing samples under
classic jerk (prusa-mk3s, with and without its planner buffer) and Klipper's square-corner
velocity (voron24, with and without a buffer; the Klipper sample's own profile), mixed
into ragged calls; on random perturbations of them; on synthetic groups of one row and of
one segment; and through the candidates' _Finisher (the windowed candidates of a head of
the gyroid plate, or of a sample: the same tables with the ragged call and without)."""
import dataclasses
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gcode_opt import chains, schedule
from gcode_opt import features as feat
from gcode_opt.detect import auto_profile
from gcode_opt.laws import chain as chain_law
from gcode_opt.pipeline import Options, analyse, process
from gcode_opt.profile import load_profile

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
PLATE = Path.home() / ".cache" / "gcode-opt-corpus" / "plate_gyroid.gcode"
CORE = chain_law.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "chain_finish_ragged"), reason="no chain core")

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


def _batches(tmp_path_factory, name):
    """The batches (sts, gs, own, vk, tk, rules, profile) that _finish_stacked_dt gets with
    predict while a head of the sample (the Klipper sample: all of it) is processed, with
    the ragged call off."""
    if name in _BATCHES:
        return _BATCHES[name]
    sample, pname, buf = CASES[name]
    src = SAMPLES / sample
    d = tmp_path_factory.mktemp("ragged")
    head = d / sample
    with open(src) as fh:
        head.write_text("".join(fh.readlines()[:None if name == "klipper_auto" else 6000]))
    prof = auto_profile(str(src)).profile if pname is None else load_profile(pname)
    if buf is not None:
        prof = dataclasses.replace(prof, block_buffer=buf)
    if name in TIGHT_JD:
        prof = dataclasses.replace(prof, junction_deviation_d=TIGHT_JD[name])
    got = []
    orig, orig_r = chains._finish_stacked_dt, chains._finish_ragged

    def spy(sts, gs, own, vk, tk, rules, profile, predict=True, du=None):
        if predict:
            got.append((list(sts), list(gs), np.array(own), np.array(vk), np.array(tk), rules, profile))
        return orig(sts, gs, own, vk, tk, rules, profile, predict, du)

    chains._finish_stacked_dt = spy
    chains._finish_ragged = lambda *a, **k: None
    try:
        process(str(head), str(d / "out.gcode"), prof, Options())
    finally:
        chains._finish_stacked_dt, chains._finish_ragged = orig, orig_r
    assert got, name
    _BATCHES[name] = got
    return got


def _bits(x):
    return None if x is None else (x.shape, x.dtype.str, np.ascontiguousarray(x).view(np.uint8).tobytes())


def _same(got, want):
    return len(got) == len(want) and all(_bits(a) == _bits(b) for a, b in zip(got, want))


def _per_batch(bs):
    return [chains._finish_stacked_dt(*b[:5], b[5], b[6]) for b in bs]


def _ragged(bs):
    return chains._finish_ragged([b[:5] for b in bs], bs[0][5], bs[0][6])


def _check(bs):
    got = _ragged(bs)
    assert got is not None
    want = _per_batch(bs)
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert _same(g, w)


@needs_core
@pytest.mark.parametrize("name", list(CASES))
def test_ragged_equals_per_batch_on_real_batches(tmp_path_factory, name):
    bs = _batches(tmp_path_factory, name)
    counts = {b[3].shape[1] - 1 for b in bs}
    assert len(counts) >= 5                       # several segment counts in one call
    _check(bs)
    _check(bs[::-1])                              # in another order
    for a in range(0, len(bs), 7):                # and in short runs
        _check(bs[a:a + 7])
    assert sum(b[3].shape[0] for b in bs) >= 100


def _perturbed(b, rng):
    sts, gs, own, vk, tk, rules, prof = b
    R = vk.shape[0]
    vk = vk * rng.uniform(0.3, 1.6, vk.shape)
    tk = tk * rng.uniform(0.5, 2.0, tk.shape)
    vk[rng.random(vk.shape) < 0.05] = 0.0         # stops at some knots
    flat = rng.random(R) < 0.2                     # rows of one speed: ramps of 0 (cruises)
    vk[flat] = vk[flat, :1]
    tk[rng.random(tk.shape) < 0.02] = 1e-14        # near-zero durations
    tk[rng.random(tk.shape) < 0.02] *= 1e3         # very long ones
    return (sts, gs, own, vk, tk, rules, prof)


@needs_core
@pytest.mark.parametrize("name", list(CASES))
def test_ragged_equals_per_batch_on_perturbed_batches(tmp_path_factory, name):
    rng = np.random.default_rng(52)
    bs = _batches(tmp_path_factory, name)
    taken = 0
    for _ in range(4):
        ps = [_perturbed(b, rng) for b in bs]
        got = _ragged(ps)
        if got is None:            # a jerk tent input <= 0 somewhere: a batch's core declines too
            assert any(chains._finish_core(*p[:5], p[5], p[6], True) is None for p in ps)
            continue
        taken += 1
        for g, w in zip(got, _per_batch(ps)):
            assert _same(g, w)
    assert taken >= 2


class _Geom(SimpleNamespace):
    """A geometry of another make (curves.stack_du then stacks its rows itself)."""


def _cut(st, g, k):
    """A chain of the first k segments of st's geometry g (a stroke-like namespace: the fields
    _cf_row, _a_top and the numpy finishing read)."""
    u = np.array(g.u[:k], float)
    geo = _Geom(d=np.array(g.d[:k], float), u=u, cos_turn=np.einsum("ij,ij->i", u[:-1], u[1:]))
    s = SimpleNamespace(accel=st.accel, lim=st.lim, v_feed=st.v_feed, v0=st.v0, v1=st.v1,
                        prev_u=st.prev_u, next_u=st.next_u)
    return s, geo


def _synthetic(b, k, rows, rng):
    """A batch of the chains of b cut to k segments, `rows` rows each, speeds and durations
    drawn around b's first row's."""
    sts, gs, own, vk, tk, rules, prof = b
    cut = [_cut(st, g, k) for st, g in zip(sts, gs)]
    m = len(cut)
    own = np.repeat(np.arange(m, dtype=np.int64), rows)
    R = own.size
    v = np.empty((R, k + 1))
    v[:, :k] = vk[0, :k] * rng.uniform(0.5, 1.5, (R, k))
    v[:, k] = vk[0, -1]
    t = tk[0, :k] * rng.uniform(0.7, 1.5, (R, k))
    return ([c[0] for c in cut], [c[1] for c in cut], own, v, t, rules, prof)


@needs_core
@pytest.mark.parametrize("name", ["mk3s", "voron", "klipper_auto", "ender3"])
def test_ragged_on_one_row_and_one_segment_groups(tmp_path_factory, name):
    rng = np.random.default_rng(7)
    real = [b for b in _batches(tmp_path_factory, name) if b[3].shape[1] >= 5]
    b = real[0]
    one = (b[0][:1], b[1][:1], np.zeros(1, np.int64), b[3][:1].copy(), b[4][:1].copy(), b[5], b[6])
    bs = [_synthetic(b, 1, 3, rng), one, _synthetic(b, 2, 1, rng), _synthetic(real[-1], 1, 1, rng),
          _synthetic(b, 4, 2, rng), real[-1]]
    assert {x[3].shape[1] - 1 for x in bs} >= {1, 2, 4}
    _check(bs)
    _check([bs[1], bs[0]])
    _check([bs[0], bs[3]])                          # two groups of one segment


@needs_core
def test_ragged_declines_non_finite_and_falls_back(tmp_path_factory):
    for name in ("mk3s", "voron"):
        bs = _batches(tmp_path_factory, name)[:6]
        for col, val in ((3, np.nan), (4, np.inf)):
            x = bs[2][col].copy()
            x[0, 1] = val
            bad = list(bs)
            bad[2] = bs[2][:col] + (x,) + bs[2][col + 1:]
            assert _ragged(bad) is None
    b = _batches(tmp_path_factory, "voron")[:3]
    assert chains._finish_ragged([x[:5] for x in b], b[0][5], b[0][6], core=False) is None

    class Stale:                                     # an older build: no chain_finish_ragged
        pass
    assert chains._finish_ragged([x[:5] for x in b], b[0][5], b[0][6], core=Stale()) is None


def _candidate_tables(path, K, ragged):
    """The candidate step's tables (schedule.candidates_in_windows over K windows, or the one
    call for K 0) with the ragged finishing on or off, and how many ragged calls took batches."""
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(str(path))[0])
    strokes, _ = analyse(str(path), prof, opts)
    pin = schedule.plan_inputs(strokes, prof, opts)
    rows = schedule._rows_by_kind(strokes, schedule._plan_kind_codes_of(strokes, pin))
    failed = schedule._faults_of(pin.fault)
    orig = chains._finish_ragged
    used = [0]

    def spy(*a, **k):
        got = orig(*a, **k)
        used[0] += got is not None
        return got
    chains._finish_ragged = spy if ragged else (lambda *a, **k: None)
    try:
        if K == 0:
            got = schedule._candidates(strokes, pin, prof, opts, rows, failed)
        else:
            bounds = np.linspace(0, len(strokes), K + 1).astype(int)
            # (a call a window, chain_batch 1: the windows' own finishing calls, as before memo53's batches)
            got = schedule.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds, None, False,
                                                 chain_batch=1)
    finally:
        chains._finish_ragged = orig
    return got, used[0]


def _table_bits(x, depth=0):
    """The candidates' tables as bytes (arrays' bits, lists and tuples walked)."""
    if isinstance(x, np.ndarray):
        return _bits(x)
    if isinstance(x, (list, tuple)):
        return [_table_bits(y, depth + 1) for y in x]
    if isinstance(x, dict):
        return {k: _table_bits(v, depth + 1) for k, v in x.items()}
    if hasattr(x, "__dict__") and depth < 3:
        return {k: _table_bits(v, depth + 1) for k, v in vars(x).items()}
    if hasattr(x, "__slots__") and depth < 3:
        return {k: _table_bits(getattr(x, k, None), depth + 1) for k in x.__slots__}
    return repr(x) if isinstance(x, (int, float, str, bool, type(None))) else type(x).__name__


@needs_core
@pytest.mark.parametrize("K", [0, 6])
def test_candidates_same_with_ragged_finishing(tmp_path, K):
    if PLATE.exists():                               # a head of the real gyroid plate
        src = tmp_path / "plate_head.gcode"
        with open(PLATE) as fh:
            src.write_text("".join(fh.readline() for _ in range(40000)))
    else:
        src = SAMPLES / "prusa_gyroid.gcode"
    on, used = _candidate_tables(src, K, True)
    off, unused = _candidate_tables(src, K, False)
    assert used >= (1 if K == 0 else K // 2) and unused == 0
    assert _table_bits(on) == _table_bits(off)
