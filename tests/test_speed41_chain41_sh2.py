"""Session 41 (chain41): the final laws' shc(γ/2) in _flat_figures_core is the one their last
active-set step's lite law made (_Step.sh2, kept by FlatLaws.take with the pieces, ordered by
close), not np.sinh of the same γ/2 again.  On real chains of the bundled full-speed gyroid
(both junction laws, cold and warm, several durations): the kept shc(γ/2) must be
line._shc(γ/2) of the final pieces bit for bit, and the figures (∫ṡ², peak and least speed)
those made without it."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc
from gcode_opt.laws.line import _shc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _solve(fl, warm_from=None):
    m, nv = fl.S.size, fl.sv.size
    if warm_from is None:
        return lc.solve_flat(fl, lc.cold_binding(fl), np.zeros(nv), np.zeros(m, bool), pieces=False)
    return lc.solve_flat(fl, warm_from.bound.copy(), warm_from.vert_t * 1.0, np.ones(m, bool), pieces=False)


def _flats(prof):
    sts, T0, profile = _chain_problems(prof)
    for r in (1.0, 1.07, 1.3):
        T = T0 * r
        yield lc._Flat(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_kept_sh2_is_shc_of_the_final_pieces(prof, monkeypatch):
    seen = []
    orig = lc._flat_figures_core

    def rec(core, res, sh2=None):
        assert sh2 is not None                 # (every step's law was a lite one: kept)
        seen.append((np.array(sh2), res.T.copy(), res.beta.copy()))
        return orig(core, res, sh2)
    monkeypatch.setattr(lc, "_flat_figures_core", rec)
    first = None
    for fl in _flats(prof):
        first = _solve(fl, None)
        _solve(fl, first)
    assert len(seen) == 6 and sum(s.size for s, _, _ in seen) > 300
    for sh2, T, beta in seen:
        gs = T / np.sqrt(beta)                 # (_figure_law's γ: all below GAMMA_SWITCH here)
        assert np.array_equal(_bits(sh2), _bits(_shc(gs / 2)))


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_figures_same_with_and_without_kept_sh2(prof, monkeypatch):
    got = []
    for fl in _flats(prof):
        a = _solve(fl, None)
        got.append((a, _solve(fl, a)))
    orig = lc._flat_figures_core
    monkeypatch.setattr(lc, "_flat_figures_core", lambda core, res, sh2=None: orig(core, res, None))
    n = 0
    for fl, (a, b) in zip(_flats(prof), got):
        ra = _solve(fl, None)
        for x, y in ((a, ra), (b, _solve(fl, ra))):
            for f in ("iv", "peak_v", "min_v", "vert_v", "vert_t", "piece_T"):
                assert np.array_equal(_bits(getattr(x, f)), _bits(getattr(y, f))), f
            n += x.iv.size
    assert n > 300


def test_a_step_without_sh2_turns_the_keeping_off(monkeypatch):
    """A step whose law kept no shc(γ/2) (not a lite law): the parts taken before it have
    it, those after not; close then makes it as before (the same figures)."""
    fls = list(_flats("voron24"))
    want = [_solve(fl, None) for fl in fls]
    orig = lc._Flat.solve_fixed
    n = [0]

    def drop_second(self, *a):
        st = orig(self, *a)
        n[0] += 1
        if n[0] % 3 == 2:
            st.sh2 = None
        return st
    seen = []
    orig_fig = lc._flat_figures_core

    def rec(core, res, sh2=None):
        seen.append(sh2 is None)
        return orig_fig(core, res, sh2)
    monkeypatch.setattr(lc._Flat, "solve_fixed", drop_second)
    monkeypatch.setattr(lc, "_flat_figures_core", rec)
    got = [_solve(fl, None) for fl in fls]
    assert any(seen)
    for x, y in zip(got, want):
        for f in ("iv", "peak_v", "min_v", "vert_v", "vert_t", "piece_T"):
            assert np.array_equal(_bits(getattr(x, f)), _bits(getattr(y, f))), f
