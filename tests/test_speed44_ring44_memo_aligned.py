"""ring_solve's memo read index for index (session 44): where the memo was made on the very
times of the stream that reads it (Y's stream after X's on the same events), event i takes
memo entry i -- if made in a restart from the same time -- instead of searching the memo by
time.  Reference: the same calls with the memo searched (one more entry past the last time:
not aligned) and without a memo (every exponential from libm): the same sum, peak and last
amplitude, bit for bit; entries made in a restart from another time are not taken."""
import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw

CORE = fw._core
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                                reason="the compiled firmware core is not built here")


def _events(rng, n):
    """Sorted event times with runs at one time and long pauses (restarts apart)."""
    gaps = rng.exponential(0.01, n) * (rng.uniform(size=n) > 0.4)
    gaps[rng.uniform(size=n) < 0.004] *= 3000.0
    return np.cumsum(gaps) + rng.uniform(0.0, 5.0)


def _jumps(rng, n):
    dr = rng.normal(size=n) * 1e-5 * (rng.uniform(size=n) < 0.8)
    drp = rng.normal(size=n) * 1e-2 * (rng.uniform(size=n) < 0.5)
    return dr, drp


def _bits(ret):
    i_r2, peak, c_last = ret
    return np.float64(i_r2).tobytes(), np.float64(peak).tobytes(), np.complex128(c_last).tobytes()


def _memo_of(memo, amps, pieces=None):
    """A RingMemo holding the amps given and memo's pieces (or those given)."""
    m = res.RingMemo()
    m.key, m.amps, m.key_p, m.pieces = memo.key, amps, memo.key_p, memo.pieces if pieces is None else pieces
    return m


@pytest.mark.parametrize("seed", range(6))
def test_aligned_memo_gives_the_searched_and_the_memoless_numbers(seed):
    rng = np.random.default_rng(seed)
    osc = res.Oscillator([50.0, 37.0, 80.0][seed % 3], [0.1, 0.05, 0.2][seed % 3])
    n = 4000 + 700 * seed
    t = _events(rng, n)
    first = None if seed % 2 else complex(rng.normal() * 1e-6, rng.normal() * 1e-6)
    k = 0 if first is None else 1
    lead = res.RingMemo()
    dr_x, drp_x = _jumps(rng, n - k)
    assert res._solve_core(osc.s, osc.wd) is not None
    assert osc.solve(t, dr_x, drp_x, first, lead, True) is not None
    mt, mt0, mv = (np.array(a, copy=True) for a in lead.amps)
    assert mt.tobytes() == t.tobytes() and len(set(mt0.tolist())) > 2       # restarts apart
    dr, drp = _jumps(rng, n - k)
    want = _bits(osc.solve(t, dr, drp, first))                               # no memo: libm
    aligned = _bits(osc.solve(t, dr, drp, first, _memo_of(lead, (mt, mt0, mv))))
    # searched: one entry more (a time past the last), so not the stream's own times
    more = (np.append(mt, mt[-1] + 1.0), np.append(mt0, mt[-1] + 1.0), np.append(mv, [1.0, 1.0, 1.0, 0.0]))
    pt, pd, pv = (np.array(a, copy=True) for a in lead.pieces)
    assert pt.tobytes() == t[:-1].tobytes()
    p_more = (np.append(pt, pt[-1] + 1.0), np.append(pd, 0.5), np.append(pv, [1.0, 1.0, 0.0]))
    searched = _bits(osc.solve(t, dr, drp, first, _memo_of(lead, more, p_more)))
    assert aligned == want and searched == want
    # an entry made in a restart from another time is not taken: its numbers (here made
    # wrong) must not show
    other = mt0.copy()
    moved = rng.uniform(size=n) < 0.3
    other[moved] = np.nextafter(other[moved], np.inf)
    wrong = mv.copy().reshape(-1, 4)
    wrong[moved] *= 1.0 + 2.0 ** -30
    assert _bits(osc.solve(t, dr, drp, first, _memo_of(lead, (mt, other, wrong.ravel())))) == want
    # and the entries of the same restart are read (the memo's numbers show when wrong)
    wrong = mv * (1.0 + 2.0 ** -30)
    assert _bits(osc.solve(t, dr, drp, first, _memo_of(lead, (mt, mt0, wrong)))) != want
    # and the memo as the stream after X's reads it (Oscillator.solve's arrays)
    assert _bits(osc.solve(t, dr, drp, first, lead)) == want
