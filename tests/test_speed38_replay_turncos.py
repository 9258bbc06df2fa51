"""Issue 8 (s38, replay): the chain finishing's turn cosines by the chain core.

chains._turn_cosines(U, core) is np.einsum("mij,mij->mi", U[:, :-1], U[:, 1:]) (what
_finish_core called): by the core's turn_cosines, each turn's two products added to
einsum's zero start in its order, where U is C-contiguous doubles; else einsum itself.
Held to einsum bit for bit on random directions and on special values (signed zeros whose
products sum to -0.0, nans, infinities, subnormals, overflowing products), for every
shape the finishing meets, and the finishing itself (chain_finish's inputs) unchanged on
real chains."""
import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.laws import chain as chain_law

from chain_cases import fresh_chains, float_bits

CORE = chain_law.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "turn_cosines"),
                                reason="chain core not built")


def _einsum(U):
    return np.einsum("mij,mij->mi", U[:, :-1], U[:, 1:])


def _directions(rng, m, n, special):
    a = rng.uniform(0, 2 * np.pi, (m, n))
    U = np.stack([np.cos(a), np.sin(a)], axis=2)
    if special and U.size:
        vals = np.array([0.0, -0.0, np.nan, np.inf, -np.inf, 5e-324, -5e-324, 1e300, -1e300, 1.0, -1.0])
        k = max(1, U.size // 5)
        U.ravel()[rng.integers(0, U.size, k)] = vals[rng.integers(0, vals.size, k)]
    return U


@needs_core
@pytest.mark.parametrize("seed", range(6))
def test_as_einsum(seed):
    rng = np.random.default_rng(seed)
    for m in (0, 1, 2, 7, 130):
        for n in (2, 3, 5, 21, 40):
            for special in (False, True):
                U = _directions(rng, m, n, special)
                got = chains._turn_cosines(U, CORE)
                want = _einsum(U)
                assert got.shape == want.shape and got.dtype == want.dtype
                assert float_bits(got) == float_bits(want)


@needs_core
def test_signed_zero_sums_are_einsums():
    """Products -0.0 and -0.0: einsum's sum starts at +0.0, so +0.0 (x0 y0 + x1 y1 alone is -0.0)."""
    U = np.array([[[-0.0, 1.0], [1.0, -0.0], [0.0, -1.0], [-0.0, -0.0]]])
    got, want = chains._turn_cosines(U, CORE), _einsum(U)
    assert float_bits(got) == float_bits(want)
    assert not np.signbit(got).any()


@needs_core
def test_not_contiguous_or_not_doubles_is_einsum():
    rng = np.random.default_rng(3)
    U = _directions(rng, 9, 12, True)
    for V in (U[::2], U[:, ::-1], _directions(rng, 9, 12, False).astype(np.float32), np.asfortranarray(U)):
        got, want = chains._turn_cosines(V, CORE), _einsum(V)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
    assert chains._turn_cosines(U, False).tobytes() == _einsum(U).tobytes()
    assert chains._turn_cosines(U, None).tobytes() == _einsum(U).tobytes()


@needs_core
def test_core_refuses_bad_shapes():
    U = np.zeros((3, 4, 2))
    with pytest.raises(ValueError):
        CORE.turn_cosines(U, 3, 5, np.empty((3, 4)))
    with pytest.raises(ValueError):
        CORE.turn_cosines(U, 3, 4, np.empty((3, 4)))
    with pytest.raises(ValueError):
        CORE.turn_cosines(U, 3, 4, U.reshape(-1)[:9])      # the output over the input


@needs_core
@pytest.mark.parametrize("path,prof_name", [("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
                                            ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24")])
def test_real_chains_directions(path, prof_name):
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    gs = [curves.geom(strokes[i], prof) for i in rows.tolist()]
    by_n = {}
    for g in gs:
        by_n.setdefault(g.d.size, []).append(g)
    for n, grp in by_n.items():
        if n > 1:
            _, U = curves.stack_du(grp)
            assert float_bits(chains._turn_cosines(U, CORE)) == float_bits(_einsum(U))
