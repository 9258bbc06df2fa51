"""Session 38, the ringing's CPU (helper "ringc"): the time of a chunk's rows
(Collector._flush's float(m[r0:r1, 6:9].sum())) by the core's ring_rows_time, numpy's
strided sum's bits (its buffered reduction: pairwise sums of 8190 values added in order)
without its per-row copies.  Held to numpy bit for bit on sizes about its buffer (one,
two, several), empty and one-row ranges, zeros of both signs, varied magnitudes; the
once-a-process probe turns a core that differs off; the Collector's figures are the same
either way."""
import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware import simulate as fw

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_rows_time"),
                               reason="the compiled firmware core is not built here")


def _rows(rng, k):
    m = rng.uniform(-1.0, 1.0, (k, 12)) * 10.0 ** rng.integers(-12, 8, (k, 12))
    m[:, 6:9] = np.abs(m[:, 6:9])
    z = rng.uniform(size=(k, 3))
    m[:, 6:9][z < 0.1] = 0.0
    m[:, 6:9][(z >= 0.1) & (z < 0.15)] = -0.0
    return m


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_rows_time_is_numpys_sum(seed):
    rng = np.random.default_rng(3830 + seed)
    sizes = list(range(0, 12)) + [2729, 2730, 2731, 2732, 4095, 4096, 4097, 5460, 5461, 5462, 8191, 13000] \
        + list(rng.integers(1, 20000, 25))
    for k in sizes:
        m = _rows(rng, int(k) + 2)
        n = len(m)
        for a, b in ((0, n), (1, n), (0, n - 1), (1, n - 1), (1, 1), (n, n), (2, 1)):
            got = CORE.ring_rows_time(m, a, b)
            want = float(m[a:b, 6:9].sum())
            assert np.float64(got).tobytes() == np.float64(want).tobytes(), (k, a, b)


@need_core
def test_rows_time_zeros_signs_and_other_columns():
    """Only columns 6..8 count; sums of zeros only are numpy's +0.0."""
    for k in (1, 3, 2731, 6000):
        m = np.full((k, 12), np.nan)
        m[:, 6:9] = -0.0
        assert np.float64(CORE.ring_rows_time(m, 0, k)).tobytes() == np.float64(m[:, 6:9].sum()).tobytes()
        m[:, 6:9] = 0.0
        m[k // 2, 7] = 2.5
        assert CORE.ring_rows_time(m, 0, k) == 2.5


@need_core
def test_rows_time_rejects_bad_rows():
    with pytest.raises(ValueError):
        CORE.ring_rows_time(np.zeros(13), 0, 1)
    with pytest.raises(ValueError):
        CORE.ring_rows_time(np.zeros((3, 12)), 0, 4)
    with pytest.raises(ValueError):
        CORE.ring_rows_time(np.zeros((3, 12)), -1, 2)


@need_core
def test_probe_turns_a_differing_core_off(monkeypatch):
    class Off:
        """The core, but its ring_rows_time one ulp off past numpy's buffer."""
        def __getattr__(self, name):
            return getattr(CORE, name)

        @staticmethod
        def ring_rows_time(m, a, b):
            x = CORE.ring_rows_time(m, a, b)
            return float(np.nextafter(x, np.inf)) if b - a > 2730 else x
    monkeypatch.setattr(fw, "_core", Off())
    monkeypatch.setattr(rg, "_ROWS_TIME_OK", None)
    assert rg._rows_time_core() is None
    m = _rows(np.random.default_rng(3839), 5000)
    assert np.float64(rg._rows_time(m, 1, 4999)).tobytes() == np.float64(m[1:4999, 6:9].sum()).tobytes()
    monkeypatch.setattr(fw, "_core", CORE)
    monkeypatch.setattr(rg, "_ROWS_TIME_OK", None)
    assert rg._rows_time_core() is CORE


@need_core
@pytest.mark.parametrize("chunk_blocks", [700, 4096])
def test_collector_time_is_the_same(monkeypatch, chunk_blocks):
    """A Collector's figures (time_s among them) with the core's sum and with numpy's, over
    rows of blocks and rests cut into chunks of several sizes."""
    rng = np.random.default_rng(3840 + chunk_blocks)
    k = 9000
    m = np.zeros((k, 12))
    ang = rng.uniform(0, 2 * np.pi, k)
    m[:, 0], m[:, 1] = np.cos(ang), np.sin(ang)
    m[:, 3] = rng.uniform(5, 200, k)
    m[:, 5] = rng.uniform(500, 5000, k)
    m[:, 6] = rng.exponential(0.01, k) * (rng.uniform(size=k) < 0.8)
    m[:, 7] = rng.exponential(0.02, k) * (rng.uniform(size=k) < 0.5)
    m[:, 8] = rng.exponential(0.01, k)
    m[:, 11] = 1.0
    rest = rng.uniform(size=k) < 0.05
    m[rest] = 0.0
    m[rest, 7] = rng.exponential(0.5, rest.sum())
    m[rest, 9] = 1.0
    m[rest, 10] = -1
    from array import array
    figs = []
    for use in (True, False):
        monkeypatch.setattr(rg, "USE_ROWS_TIME", use)
        col = rg.Collector(None, chunk_blocks=chunk_blocks, parts=False)
        col.add_rows(array("d", m.tobytes()))
        figs.append(col.figures())
    assert figs[0] == figs[1] and figs[0]["time_s"] > 0
    assert repr(figs[0]["time_s"]) == repr(figs[1]["time_s"])
