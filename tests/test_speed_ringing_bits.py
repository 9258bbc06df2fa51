"""Ringing at less cost, the same bits (issue 8): the compiled firmware core writes each
planned block's row straight into a RowSink (no Block object, no attrgetter), the
Collector's chunk work skips what its figures do not read (path length and position
without a shaper), makes each axis' jumps once for its four parts, sorts events only when
they are out of order, and integrates r^2 over finite pieces without masks and with the
real part of the complex quotient only (Oscillator.integral_r2_fin); the complex
exponentials np.exp(-lam t), np.exp(lam t), np.exp(2 lam d) come from the core (ring_exps,
ring_exp: libm's exp, cos, sin, as numpy's complex exp; cos and sin shared by the pair),
each complex factor checked against numpy on a probe before use.

Reference: the c8abe7b code of the chunk work (_pieces, _Stream.add/_solve, the _flush
loop, Oscillator.amplitudes; integral_r2 is unchanged), copied below, fed by the Python rows (ringing.USE_SINK off: pend + _drain).  The
figures must be equal (==, every float bit for bit) on real files, with and without input
shapers, on hand-made files with rests, dwells and barriers, and with chunks forced small.
Since session 46 the core's ring_solve (on by default) makes the amplitudes by their
recursion: with it the figures are the reference's to rounding (ring_close); without it
(the probe and pure-Python tests) bit for bit as before."""
import math
import os
from array import array

import numpy as np
import pytest

from ring_close import assert_figures_close
from gcode_opt import ringing as rg
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator, shaped_events
from gcode_opt.profile import load_profile
from gcode_opt import state as st
from gcode_opt.state import read_lines

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus")
HAS_SINK = fw._core is not None and hasattr(fw._core, "RowSink")
need_sink = pytest.mark.skipif(not HAS_SINK, reason="the compiled firmware core is not built here")
HAS_EXPS = fw._core is not None and hasattr(fw._core, "ring_exps")
need_exps = pytest.mark.skipif(not HAS_EXPS, reason="the compiled firmware core is not built here")


# ---------------------------------------------------------------- the c8abe7b chunk work
def _ref_pieces(m, c):
    ux, uy, sv, cv, ev, a, at, ct, dt, after, idx, isb = m.T
    dur = np.stack([at, ct, dt], 1).ravel()
    speed = np.stack([sv, cv, cv], 1).ravel()
    tan_a = np.stack([a, 0.0 * a, -a], 1).ravel()
    u = np.repeat(np.stack([ux, uy], 1), 3, axis=0)
    vel = speed[:, None] * u
    acc = tan_a[:, None] * u
    end_speed = speed + tan_a * dur
    vel_end = end_speed[:, None] * u
    cs = np.cumsum(dur)
    t0 = c.t + np.concatenate([[0.0], cs[:-1]])
    ds = speed * dur + 0.5 * tan_a * dur * dur
    cs_s = np.cumsum(ds)
    s = c.s + np.concatenate([[0.0], cs_s[:-1]])
    cs_p = np.cumsum(ds[:, None] * u, axis=0)
    pos = c.pos + np.vstack([[0.0, 0.0], cs_p[:-1]])
    n = len(dur)
    starts = np.zeros(n, bool)
    starts[::3] = True
    prev_end = np.vstack([c.vel_end, vel_end[:-1]])
    dv = np.where(starts[:, None], vel - prev_end, 0.0)
    da = acc - np.vstack([c.acc, acc[:-1]])
    cls = np.zeros(n, np.int8)
    pux, puy, pisb = np.concatenate([[c.ux], ux[:-1]]), np.concatenate([[c.uy], uy[:-1]]), \
        np.concatenate([[c.isb], isb[:-1]])
    cos_turn = ux * pux + uy * puy
    moving_pair = (isb > 0) & (pisb > 0) & (after == 0)
    gentle = moving_pair & (cos_turn >= fw.CORNER_COS)
    cls[::3] = np.where(gentle, rg.TURN, rg.CORNER)
    c.t, c.s = c.t + float(cs[-1]), c.s + float(cs_s[-1])
    c.pos = c.pos + cs_p[-1]
    c.vel_end, c.acc = vel_end[-1].copy(), acc[-1].copy()
    c.ux, c.uy, c.isb = float(ux[-1]), float(uy[-1]), float(isb[-1])
    return rg.Trace(dict(t0=t0, dur=dur, acc=acc, vel=vel, dv=dv, da=da, pos=pos, s=s,
                         speed=speed, tan_a=tan_a, cls=cls, idx=np.repeat(idx, 3).astype(np.int64)))


def _ref_amplitudes(osc, t_ev, dc):
    n = len(t_ev)
    c = np.empty(n, complex)
    if n == 0:
        return c
    lam = osc.lam
    span = res.CHUNK_DECAY / osc.s
    start = 0
    carry, t_carry = 0j, float(t_ev[0])
    while start < n:
        t0 = float(t_ev[start])
        stop = int(np.searchsorted(t_ev, t0 + span, side="right"))
        if stop <= start:
            stop = start + 1
        tt = t_ev[start:stop] - t0
        g = np.cumsum(dc[start:stop] * np.exp(-lam * tt))
        c0 = carry * np.exp(lam * (t0 - t_carry))
        c[start:stop] = (c0 + g) * np.exp(lam * tt)
        carry, t_carry = c[stop - 1], float(t_ev[stop - 1])
        start = stop
    return c


class _RefStream(rg._Stream):
    def add(self, t, dr, drp, horizon_t):
        t_s, (dr_s, drp_s) = shaped_events(t, (dr, drp), self.a_p, self.t_p)
        t_all = np.concatenate([self.t, t_s])
        order = np.argsort(t_all, kind="stable")
        t_all = t_all[order]
        dr_all = np.concatenate([self.dr, dr_s])[order]
        drp_all = np.concatenate([self.drp, drp_s])[order]
        k = int(np.searchsorted(t_all, horizon_t, side="left"))
        self._solve(t_all[:k], dr_all[:k], drp_all[:k])
        self.t, self.dr, self.drp = t_all[k:], dr_all[k:], drp_all[k:]

    def _solve(self, t, dr, drp):
        if len(t) == 0:
            return
        osc = self.osc
        dc = osc.jump_amplitude(dr, drp)
        if self.t_last is not None:
            t = np.concatenate([[self.t_last], t])
            dc = np.concatenate([[self.c_last], dc])
        c = _ref_amplitudes(osc, t, dc)
        if len(c) > 1:
            dur = np.diff(t)
            self.int_r2 += float(osc.integral_r2(c[:-1], dur).sum())
            self.peak = max(self.peak, osc.max_abs_r(c[:-1], dur))
        self.t_last, self.c_last = float(t[-1]), complex(c[-1])


class RefCollector(rg.Collector):
    """The Collector as c8abe7b had it: Python rows, the old chunk work."""

    def __init__(self, *a, **k):
        old, rg.USE_SINK = rg.USE_SINK, False
        try:
            super().__init__(*a, **k)
        finally:
            rg.USE_SINK = old
        assert self.sink is None
        for key, st in self.streams.items():
            ref = _RefStream(st.osc, (st.a_p, st.t_p))
            self.streams[key] = ref

    def _flush(self, final):
        self._drain()
        m = np.frombuffer(self.rows, float).reshape(-1, rg.ROW).copy()
        self.rows = array("d")
        self.room = min(self.limit // rg.ROW, rg.PEND_BLOCKS)
        if not len(m):
            return
        counted = m[1 if self.skip_first else 0:len(m) - 1 if final else len(m)]
        self.time_t += float(counted[:, 6:9].sum())
        self.skip_first = False
        self.chunks += 1
        tr = _ref_pieces(m, self.carry)
        for ax, name in enumerate("xy"):
            horizon_t = np.inf if final else self.carry.t + self.horizon[name]
            for part in ("all",) + rg.PARTS:
                dr, drp = rg._jumps(tr, self.model, name, ax, part)
                keep = np.zeros(len(tr), bool)
                for j in (dr, drp):
                    if j is not None:
                        keep |= j != 0.0
                zero = np.zeros(int(keep.sum()))
                self.streams[name, part].add(tr.t0[keep], zero if dr is None else dr[keep],
                                             zero if drp is None else drp[keep], horizon_t)
        if self.smooth is not None:
            self.smooth.add(tr, self.carry.t, final)


# ---------------------------------------------------------------- helpers
def _bits(d):
    """Every number of a figures dict as its IEEE bits (so -0.0 != 0.0 and NaN == NaN)."""
    if isinstance(d, dict):
        return {k: _bits(v) for k, v in d.items()}
    if isinstance(d, float):
        return np.float64(d).tobytes()
    return d


def _figures(path, profile, col):
    res = rg.play(path, profile, col)
    return col.figures(), res


def _assert_same_figures(path, profile, shaper=None, chunk=rg.CHUNK_BLOCKS, core=None):
    old = fw.use_core(core or fw.CORE)
    try:
        ref, ref_res = _figures(path, profile, RefCollector(profile, shaper, chunk_blocks=chunk))
        col = rg.Collector(profile, shaper, chunk_blocks=chunk)
        assert (col.sink is not None) == HAS_SINK
        got, got_res = _figures(path, profile, col)
    finally:
        fw.use_core(old)
    assert_figures_close(got, ref)
    assert got_res.as_dict() == ref_res.as_dict()       # the sink changes nothing of the model's figures
    assert ref["xy"]["rms_um"] > 0.0
    return ref, col


def _dwell_file(src, dst, every=23, eonly_every=31, max_g1=None):
    """src with a G4 dwell before every `every`-th G1 and an E-only move before every
    `eonly_every`-th one: barriers and rests among the blocks (up to max_g1 G1 lines)."""
    n = 0
    with open(dst, "w", newline="") as fo:
        for _, raw in read_lines(src):
            if raw.startswith("G1 "):
                n += 1
                if max_g1 is not None and n > max_g1:
                    break
                if n % every == 0:
                    fo.write("G4 P120\n")
                if n % eonly_every == 0:
                    fo.write("G1 E-0.4 F2100\nG1 E0.4 F2100\n")
            fo.write(raw)


# ---------------------------------------------------------------- real files
CASES = [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
         ("cura_box.gcode", "ender3"), ("prusa_gyroid.gcode", "prusa-mk3s"),
         ("prusa_gyroid_arcs.gcode", "voron24")]


@pytest.mark.parametrize("shaper", [None, "zv", "mzv", "ei"])
@pytest.mark.parametrize("name,prof", CASES)
def test_figures_equal_the_c8abe7b_chunk_work(name, prof, shaper):
    _assert_same_figures(os.path.join(SAMPLES, name), load_profile(prof), shaper)


@pytest.mark.parametrize("core", ["c", "python"])
@pytest.mark.parametrize("chunk", [1, 2, 7, 50, 333])
def test_small_chunks_rests_dwells_barriers(tmp_path, chunk, core):
    """Chunk boundaries everywhere (1 block a chunk: the first holds the idle row too),
    between a rest and its block, inside a dwell; both firmware-model cores (the Python
    model calls the sink with a planner.Block)."""
    if core == "c" and fw._core is None:
        pytest.skip("the compiled firmware core is not built here")
    path = str(tmp_path / "dwell.gcode")
    _dwell_file(os.path.join(SAMPLES, "prusa_klipper.gcode"), path, max_g1={1: 200, 2: 400, 7: 1500}.get(chunk))
    for shaper in (None, "mzv"):
        ref, col = _assert_same_figures(path, load_profile("voron24"), shaper, chunk, core)
        assert col.chunks > 3


def test_edge_files(tmp_path):
    edge = os.path.join(SAMPLES, "edge")
    for name in sorted(os.listdir(edge)):
        if name.endswith(".gcode"):
            for prof in ("prusa-mk3s", "voron24"):
                for chunk in (3, rg.CHUNK_BLOCKS):
                    path, p = os.path.join(edge, name), load_profile(prof)
                    try:
                        ref, _ = _figures(path, p, RefCollector(p, chunk_blocks=chunk))
                    except Exception as e:          # a file the model refuses: the same for both
                        with pytest.raises(type(e)):
                            _figures(path, p, rg.Collector(p, chunk_blocks=chunk))
                        continue
                    got, _ = _figures(path, p, rg.Collector(p, chunk_blocks=chunk))
                    assert_figures_close(got, ref)


def test_add_rows_then_blocks_keep_the_chunks():
    """add_rows (ready rows) then blocks and rests (some through the class' methods): rows
    left over by add_rows wait in the sink, so the next chunk is cut where the Python rows
    cut it."""
    p = load_profile("prusa-mk3s")
    rows = rg.Rows()
    rg.play(os.path.join(SAMPLES, "prusa_klipper.gcode"), p, rows)
    items = rows.items
    half = (len(items) // rg.ROW // 2) * rg.ROW
    got = {}
    for kind in ("ref", "new"):
        col = RefCollector(p, chunk_blocks=40) if kind == "ref" else rg.Collector(p, chunk_blocks=40)
        col.add_rows(items[:half])
        for i in range(half, len(items), rg.ROW):
            row = items[i:i + rg.ROW]
            cls = rg.Collector if (i // rg.ROW) % 3 == 0 else None    # now and then through the class
            if row[11] == 0.0:
                cls.rest(col, row[7]) if cls else col.rest(row[7])
            else:
                cls.on_block(col, _FakeBlock(row)) if cls else col.on_block(_FakeBlock(row))
        got[kind] = (col.figures(), col.chunks)
    assert_figures_close(got["new"][0], got["ref"][0])
    assert got["new"][1] == got["ref"][1]


class _FakeBlock:
    """A block with _block_row's attributes, from a row."""

    def __init__(self, row):
        (self.ux, self.uy, self.start_v, self.cruise_v, self.end_v, self.accel, self.accel_t,
         self.cruise_t, self.decel_t, after, idx, _) = row
        self.after_stop, self.idx = bool(after), int(idx)


# ---------------------------------------------------------------- the pieces
@pytest.mark.parametrize("seed", range(4))
def test_integral_r2_fin_is_integral_r2(seed):
    """Sizes on both sides of numpy's temporary elision (16384 complex: the product and
    the quotient then run in place), both branches of Smith's division (damping above
    and below 1/sqrt 2), zero durations and amplitudes."""
    rng = np.random.default_rng(seed)
    for n in (1, 2, 5, 8, 9, 100, 4097, 16383, 16384, 16385, 50000):
        z = float(rng.choice([0.02, 0.1, 0.5, 0.7071, 0.72, 0.95]))
        osc = Oscillator(float(rng.uniform(15.0, 120.0)), z)
        c = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * np.exp(rng.uniform(-30.0, 3.0, n))
        c[rng.random(n) < 0.05] = 0j
        dur = rng.exponential(float(rng.choice([1e-5, 1e-3, 1e-1, 3.0])), n)
        dur[rng.random(n) < 0.05] = 0.0
        assert osc.integral_r2_fin(c, dur).tobytes() == osc.integral_r2(c, dur).tobytes(), (n, z)


def test_pieces_without_position_are_the_pieces():
    p = load_profile("prusa-mk3s")
    rows = rg.Rows()
    rg.play(os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), p, rows)
    m = np.asarray(rows.items, float).reshape(-1, rg.ROW)
    ca, cb = rg._Carry(), rg._Carry()
    for lo in range(0, len(m), 999):
        a, b = _ref_pieces(m[lo:lo + 999], ca), rg._pieces(m[lo:lo + 999], cb, False)
        for key in ("t0", "dur", "acc", "vel", "dv", "da", "speed", "tan_a", "cls"):
            assert getattr(a, key).tobytes() == getattr(b, key).tobytes(), key
        assert b.pos is None and b.s is None
        for key in ("t", "ux", "uy", "isb"):
            assert getattr(ca, key) == getattr(cb, key)
        assert ca.vel_end.tobytes() == cb.vel_end.tobytes() and ca.acc.tobytes() == cb.acc.tobytes()


# ---------------------------------------------------------------- the RowSink
@need_sink
def test_row_sink_rows_and_flush():
    calls = []
    sink = fw._core.RowSink(3, lambda: calls.append(sink.take()))
    sink.put(array("d", rg.IDLE))
    sink.rest(0.0)                                  # no rest row for no time
    sink.rest(-1.0)
    assert sink.rows == 1 and not calls
    b = _FakeBlock((0.6, -0.8, 1.5, 20.0, 2.5, 1200.0, 0.01, 0.02, 0.015, 1.0, 41, 1.0))
    sink(b)
    assert not calls
    sink.rest(0.25)                                 # the third row: flush
    assert len(calls) == 1 and sink.rows == 0
    got = np.frombuffer(calls[0], float).reshape(-1, rg.ROW)
    want = np.array([rg.IDLE, rg._block_row(b), rg._rest_row(0.25)], float)
    assert got.tobytes() == want.tobytes()
    b.after_stop = False
    sink(b)
    assert np.frombuffer(sink.take(), float).tobytes() == np.array(rg._block_row(b), float).tobytes()
    with pytest.raises(ValueError):
        sink.put(b"\0" * 8)
    lazy = fw._core.RowSink(1, lambda: None)        # a flush that takes nothing is an error
    with pytest.raises(RuntimeError):
        lazy.rest(1.0)
    with pytest.raises(ValueError):
        fw._core.RowSink(0, lambda: None)


@need_sink
def test_sim_writes_block_rows_into_the_sink(tmp_path):
    """The C model writes the rows of the blocks it would hand to on_block, and the rests
    of E-only moves and dwells where ringing.hooks' on_line and wrap_events put them: the
    rows a Rows sink gets through the Python hooks, in order, with the flush at every cap
    rows; the sink's line() and dwell() then do nothing.  Played by the Python model, the
    sink's line() and dwell() write the rests."""
    path = str(tmp_path / "dwell.gcode")
    _dwell_file(os.path.join(SAMPLES, "prusa_klipper.gcode"), path, every=17, eonly_every=13)
    p = load_profile("voron24")
    for core in ("c", "python"):
        old = fw.use_core(core)
        try:
            rows = rg.Rows()
            rg.play(path, p, rows)
            want = rows.items
            got, chunks = array("d"), []

            def flush():
                chunks.append(sink.rows)
                got.frombytes(sink.take())
            sink = fw._core.RowSink(97, flush)
            fw.simulate_events(rg.wrap_events(st.events(path, p), sink.dwell), p, sink.line, sink)
            assert sink.sim_rests == (core == "c")
            got.frombytes(sink.take())
        finally:
            fw.use_core(old)
        m = np.frombuffer(want, float).reshape(-1, rg.ROW)
        assert len(m) > 1000 and (m[:, 11] == 0.0).sum() > 60        # rests among the blocks
        assert got.tobytes() == want.tobytes(), core
        assert chunks == [97] * (len(m) // 97)


# ---------------------------------------------------------------- the corpus plate
@pytest.mark.slow
@pytest.mark.skipif(not os.path.exists(os.path.join(CORPUS, "plate_gyroid.gcode")), reason="corpus not made")
@pytest.mark.parametrize("shaper", [None, "mzv"])
def test_plate_gyroid(shaper):
    """~2 x 4 s CPU: the 461 k-line plate, whose chunks hold more than 16384 events."""
    _assert_same_figures(os.path.join(CORPUS, "plate_gyroid.gcode"), load_profile("prusa-mk3s"), shaper)


def test_sink_is_used_where_the_core_is():
    col = rg.Collector(load_profile("prusa-mk3s"))
    assert (col.sink is not None) == HAS_SINK
    ring_line, on_block, on_dwell = rg.hooks(col)
    if HAS_SINK:
        assert on_block is col.sink and on_dwell == col.sink.dwell and ring_line == col.sink.line
    assert math.isfinite(col.figures()["time_s"])


# ---------------------------------------------------------------- the compiled exponentials
@need_exps
@pytest.mark.parametrize("seed", range(3))
def test_ring_exps_are_numpys(seed):
    """Every bit (signed zeros too) of np.exp(-lam t), np.exp(lam t) and
    np.exp(2 lam t) on times from 0 to past a restart's span, for oscillators of any
    damping; a time that is not finite stops the kernel (False)."""
    rng = np.random.default_rng(seed)
    core = fw._core
    for _ in range(6):
        osc = Oscillator(float(rng.uniform(10.0, 150.0)), float(rng.uniform(0.005, 0.99)))
        span = res.CHUNK_DECAY / osc.s
        t = np.concatenate([[0.0, 5e-324, 1e-300, 1e-15], rng.uniform(0.0, span, 30000),
                            rng.exponential(1e-3, 3000), np.geomspace(1e-9, 1e3, 500)])
        e1, e2, e3 = (np.empty(len(t), complex) for _ in range(3))
        assert core.ring_exps(t, osc.s, osc.wd, e1, e2)
        q = 2.0 * osc.lam
        assert core.ring_exp(t, q.real, q.imag, e3)
        with np.errstate(over="ignore", invalid="ignore"):    # past the span exp(s t) overflows
            assert e1.tobytes() == np.exp(-osc.lam * t).tobytes()
            assert e2.tobytes() == np.exp(osc.lam * t).tobytes()
            assert e3.tobytes() == np.exp(q * t).tobytes()
    for bad in (np.inf, np.nan, -np.inf):
        t = np.array([0.1, bad, 0.2])
        assert not core.ring_exps(t, 3.0, 30.0, np.empty(3, complex), np.empty(3, complex))
        assert not core.ring_exp(t, -6.0, 60.0, np.empty(3, complex))
    with pytest.raises(ValueError):
        core.ring_exp(np.zeros(3), 1.0, 1.0, np.empty(2, complex))


def test_amplitudes_and_integral_with_and_without_the_core(monkeypatch):
    """Oscillator.amplitudes and integral_r2_fin with the core's exponentials equal the
    c8abe7b amplitudes and integral_r2, with restarts short and long (numpy works a
    restart of 16384 events or more in place: those keep numpy's expressions), and with
    a probe that fails (numpy's exponentials then)."""
    rng = np.random.default_rng(3)
    osc = Oscillator(50.0, 0.1)
    span = res.CHUNK_DECAY / osc.s
    for n_per in (1, 3, 200, 16383, 16384, 20000):
        n = 3 * n_per
        t = np.sort(np.concatenate([k * span * 1.0001 + rng.uniform(0.0, span, n_per) for k in range(3)]))
        dc = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * 1e-3
        want = _ref_amplitudes(osc, t, dc)
        for use in (True, False):
            monkeypatch.setattr(res, "USE_KERNEL", use)
            assert osc.amplitudes(t, dc).tobytes() == want.tobytes(), (n_per, use)
            dur = np.diff(t)
            assert osc.integral_r2_fin(want[:-1], dur).tobytes() == osc.integral_r2(want[:-1], dur).tobytes()
    monkeypatch.setattr(res, "USE_KERNEL", True)
    monkeypatch.setattr(res, "_KERNEL_OK", {("pair", osc.s, osc.wd): False})
    t = np.cumsum(rng.exponential(1e-3, 5000))
    dc = rng.standard_normal(5000) + 0j
    assert osc.amplitudes(t, dc).tobytes() == _ref_amplitudes(osc, t, dc).tobytes()


@need_exps
def test_a_probe_that_fails_leaves_numpy(monkeypatch):
    """A core whose exponentials differ from numpy's on the probe is not used: the
    figures stay numpy's (the steps that take them: the core's ring_solve off)."""
    real = fw._core
    monkeypatch.setattr(res, "USE_SOLVE", False)

    class Off:
        """The core with a ring_exps / ring_exp one ulp off."""

        def __getattr__(self, name):
            return getattr(real, name)

        def ring_exps(self, t, s, wd, e1, e2):
            ok = real.ring_exps(t, s, wd, e1, e2)
            e1.view(np.int64)[::2] += 1
            return ok

        def ring_exp(self, t, a, b, out):
            ok = real.ring_exp(t, a, b, out)
            out.view(np.int64)[1::2] += 1
            return ok
    monkeypatch.setattr(fw, "_core", Off())
    monkeypatch.setattr(res, "_KERNEL_OK", {})
    path, p = os.path.join(SAMPLES, "prusa_klipper.gcode"), load_profile("voron24")
    ref, _ = _figures(path, p, RefCollector(p))
    got, _ = _figures(path, p, rg.Collector(p))
    assert _bits(got) == _bits(ref)
    assert res._KERNEL_OK and not any(res._KERNEL_OK.values())


@pytest.mark.parametrize("name,prof,shaper", [("prusa_gyroid.gcode", "prusa-mk3s", None),
                                              ("prusa_klipper.gcode", "voron24", "ei")])
def test_pure_python_chunk_work(monkeypatch, name, prof, shaper):
    """Without the compiled core's sink and exponentials (what GCODE_OPT_PURE_PYTHON=1
    leaves): Python rows, numpy's exponentials, the same figures."""
    monkeypatch.setattr(rg, "USE_SINK", False)
    monkeypatch.setattr(res, "USE_KERNEL", False)
    monkeypatch.setattr(res, "_KERNEL_OK", {})
    path, p = os.path.join(SAMPLES, name), load_profile(prof)
    ref, _ = _figures(path, p, RefCollector(p, shaper))
    col = rg.Collector(p, shaper)
    assert col.sink is None
    got, _ = _figures(path, p, col)
    assert _bits(got) == _bits(ref)
    assert res._KERNEL_OK == {}
