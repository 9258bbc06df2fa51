"""s63 (chc): _table_rows' knots, steps, flat places and binding masks made once for a
chunk's groups (_table_items / _knots_flat: views of one gather) are the arrays its
per-group loop makes (the path taken where the stacks are not C-contiguous), value for
value, on real files' chains, both junction laws' finishing groups; and the windowed and
list candidates stay the same bytes at small windows."""
import os

import numpy as np
import pytest

from gcode_opt import chains, pipeline, schedule
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")
CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_fullspeed_klipper.gcode", "voron24")]


def _plan(name, prof):
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)


def _fortran_stack(real):
    """_vertex_stack whose stacks are not C-contiguous (the per-group loop's gathers)."""
    def stack(res, k, names, dtype=float):
        got, vmap = real(res, k, names, dtype)
        return [np.asfortranarray(a) for a in got], vmap
    return stack


class _Failed(BaseException):
    """An assertion inside the planning (not an Exception: isolate does not catch it)."""


def _raising(fn):
    """fn, whose exceptions are not a stroke's planning failure (window_pieces' isolate
    would drop the chains and hide a failed assertion): re-raised as a BaseException."""
    def call(*a, **k):
        try:
            return fn(*a, **k)
        except AssertionError as e:
            raise _Failed("assertion in _figures: %s" % e) from e
    return call


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("cells", [None, 64])
@pytest.mark.parametrize("name,prof", CASES)
def test_chunk_items_are_the_groups_own(name, prof, cells, monkeypatch):
    """cells: the flat knots made for runs of groups of at most that many cells (64: most
    groups a run of their own, some several) instead of KNOTS_FLAT_CELLS."""
    if cells is not None:
        monkeypatch.setattr(chains, "KNOTS_FLAT_CELLS", cells)
    real_rows, real_stack = chains._table_rows, chains._vertex_stack
    seen = []

    def table_rows(sts, base, res, use, T, profile, grouped, laws=None):
        got = list(real_rows(sts, base, res, use, T, profile, grouped, laws))
        with monkeypatch.context() as m:
            m.setattr(chains, "_vertex_stack", _fortran_stack(real_stack))
            ref = list(real_rows(sts, base, res, use, T, profile, grouped, None))
        assert len(got) == len(ref)
        for g, r in zip(got, ref):
            assert all(_same(x, y) for x, y in zip(g, r))          # J, rj, rc, vk, dt, ks, iv
            assert _same(g.j, r.j)
            n = g[4].shape[1]
            assert (g.at is None) == (n < 2)
            if laws is not None:
                own = laws.rows(g.j, g[2], n)[0]         # (its own gather: no flat places given)
                assert g.bnd is not None and _same(g.bnd, own)
                if g.at is not None:                      # the inner vertices' flat places
                    assert _same(laws.rows(g.j, g[2], n, g.at)[0], own)
                seen.append(n)
        yield from got
    monkeypatch.setattr(chains, "_table_rows", table_rows)
    monkeypatch.setattr(chains, "_figures", _raising(chains._figures))
    _plan(name, prof)
    assert seen and len(set(seen)) > 2               # (groups of several segment counts met)


@pytest.mark.parametrize("window", [7, 37])
def test_small_windows_write_the_list_bytes(window, tmp_path, monkeypatch):
    from gcode_opt import cli
    src = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    outs = []
    for windowed in ("0", "1"):
        monkeypatch.setenv("GCODE_OPT_WINDOWED", windowed)
        monkeypatch.setenv("GCODE_OPT_WINDOW", str(window))
        out = tmp_path / ("w%s.gcode" % windowed)
        cli.main(["process", src, "-o", str(out), "-q", "--profile", "prusa-mk3s"])
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]


@pytest.mark.parametrize("core", [True, False])
@pytest.mark.parametrize("seed", range(6))
def test_knots_flat_rows(seed, core, monkeypatch):
    """_knots_flat's rows (one segment and more, with and without a vertex map), by the
    chain core and by numpy, against each row made alone: its ends, its gathers, its
    differences, its binding bits."""
    from gcode_opt.laws import chain as chain_law
    if core and getattr(chain_law.CORE_MOD, "knots_flat", None) is None:
        pytest.skip("no chain core")
    if not core:
        monkeypatch.setattr(chain_law, "CORE_MOD", None)
    rng = np.random.default_rng(seed)
    m, k = 9, 5
    nv = rng.integers(0, 6, m)                         # inner vertices a chain: segments - 1
    voff = np.concatenate([[0], np.cumsum(nv)]).astype(np.int64)
    W = int(voff[-1]) + 3 * (seed % 2)
    vmap = rng.permutation(W)[:voff[-1]].astype(np.int64) if seed % 2 else None
    VV, TT = rng.random((k, W)), np.cumsum(rng.random((k, W)), axis=1)
    BB = rng.random((k, W)) < 0.5
    R = 14
    jA, rcA = rng.integers(0, m, R).astype(np.int64), rng.integers(0, k, R).astype(np.int64)
    nA = nv[jA] + 1
    vo = chains._offsets(nA + 1)
    V0, V1, TL = rng.random(R), rng.random(R), 50 + rng.random(R)
    VK, DT, IDX, BND = chains._knots_flat(nA, vo, V0, V1, TL, VV, TT, vmap, voff, jA, rcA, BB)
    assert chains._knots_flat(nA, vo, V0, V1, TL, VV, TT, vmap, voff, jA, rcA)[3] is None
    for i in range(R):
        places = np.arange(voff[jA[i]], voff[jA[i] + 1])
        flat = rcA[i] * W + (places if vmap is None else vmap[places])
        vk = np.concatenate([[V0[i]], VV.ravel()[flat], [V1[i]]])
        tk = np.concatenate([[0.0], TT.ravel()[flat], [TL[i]]])
        a, n = vo[i], nA[i]
        assert _same(VK[a:a + n + 1], vk) and _same(DT[a:a + n], np.diff(tk)) and _same(IDX[a + 1:a + n], flat)
        assert _same(BND[a + 1:a + n], BB.ravel()[flat])


def test_knots_flat_core_refuses_bad_places():
    from gcode_opt.laws import chain as chain_law
    fn = getattr(chain_law.CORE_MOD, "knots_flat", None)
    if fn is None:
        pytest.skip("no chain core")
    nA, voff = np.array([3], np.int64), np.array([0, 2], np.int64)
    out = [np.empty(4), np.empty(4), np.empty(4, np.int64)]
    args = (nA, np.zeros(1), np.zeros(1), np.ones(1), np.zeros((2, 2)), np.zeros((2, 2)), None, None, voff)
    fn(*args, np.array([0], np.int64), np.array([1], np.int64), *out, None, 2)
    with pytest.raises(ValueError):           # column 2 of 2: past the stacks
        fn(*args, np.array([0], np.int64), np.array([2], np.int64), *out, None, 2)
    with pytest.raises(ValueError):           # a chain of 2 inner vertices given 1 segment
        fn(np.array([1], np.int64), *args[1:], np.array([0], np.int64), np.array([0], np.int64), *out[:2],
           out[2][:2], None, 2)
