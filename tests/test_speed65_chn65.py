"""Issue 8 (s65, the chains): the chain core reads its arrays without asking numpy for
their format strings (only their item size is checked: numpy builds and compares a format
string a buffer when asked, ~30 k instructions an active-set step); FlatLaws.take's tests
by one count.  These tests hold that the core still refuses what it refused (items of
another size, a strided array, a read-only output) and reads what it read (knot_times'
sums = the numpy path's), and that take keeps nothing, all or some chains as before."""
import numpy as np
import pytest

from gcode_opt.laws import chain as lc

needs_core = pytest.mark.skipif(lc.CORE_MOD is None, reason="chain core not built")


@needs_core
def test_core_buffers_checked_without_format():
    core = lc.CORE_MOD
    Tj = np.array([0.5, 0.25, 1.0, 2.0, 0.125])
    koff = np.array([0, 3, 7], np.int64)        # 2 chains of 2 and 3 pieces: 3 and 4 knots
    kt = np.empty(7)
    core.knot_times(Tj, koff, kt)
    assert kt.tolist() == [0.0, 0.5, 0.75, 0.0, 1.0, 3.0, 3.125]     # each chain's running sums
    with pytest.raises(TypeError):               # float32: items of 4 bytes
        core.knot_times(Tj.astype(np.float32), koff, np.empty(7))
    with pytest.raises((TypeError, ValueError, BufferError)):   # not C-contiguous
        core.knot_times(np.repeat(Tj, 2)[::2], koff, np.empty(7))
    ro = np.empty(7)
    ro.flags.writeable = False
    with pytest.raises((TypeError, ValueError, BufferError)):   # the output read-only
        core.knot_times(Tj, koff, ro)


class _St:
    pass


def _step(done_n, na=4):
    st = _St()
    st.active = np.arange(na, dtype=np.int64)
    st.conv = np.ones(na, bool)
    st.lam = np.arange(na, dtype=float)
    st.koff = np.array([0, 2, 5, 7, 10], np.int64)[:na + 1]
    P = int(st.koff[-1]) - na
    for f in ("L", "Tj", "beta", "va", "vb", "a0", "a1"):
        setattr(st, f, np.arange(P, dtype=float) + len(f))
    st.sh2 = None
    done = np.zeros(na, bool)
    done[:done_n] = True
    return st, done


@pytest.mark.parametrize("done_n", [0, 2, 4])
def test_take_none_some_all(done_n):
    fl = _St()
    fl.S, fl.sv = np.ones(4), np.zeros(0)
    res = lc.FlatLaws(fl, pieces=False)
    st, done = _step(done_n)
    res.take(st, done, np.zeros(4, bool), verts=False)
    if done_n == 0:
        assert res._parts == []
        return
    (part,) = res._parts
    assert part[0].tolist() == list(range(done_n))
    npc = (np.diff(st.koff) - 1)[:done_n]
    assert part[1].tolist() == npc.tolist()
    assert part[2].size == int(npc.sum()) and res.conv[:done_n].all() and not res.conv[done_n:].any()
