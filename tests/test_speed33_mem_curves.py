"""Session 33 of issue 8 (memory) in curves.candidates_curve: the curve candidates' circle
laws solved and probed SOLVE_ROWS at a time, only the laws not surely over a limit kept
for their figures, on the grid of the whole batch (its panel levels: the largest of its
chunks'); a batch in which Newton took part is solved whole, as before.  The same
candidate tables, bit for bit."""
import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse, plan_inputs
from gcode_opt.profile import load_profile

S = "sample_gcode/"


def _tables(monkeypatch, name, solve_rows):
    """candidate_curve's tables of the sample's curve strokes at SOLVE_ROWS = solve_rows,
    the sizes of the batches solve_circles was given and their panel levels."""
    prof = load_profile("prusa-mk3s")
    opts = Options()
    strokes, _ = analyse(S + name, prof, opts)
    pin = plan_inputs(strokes, prof, opts)
    rows = np.array([i for i, s in enumerate(strokes) if chains.plan_kind(s) == "curve" and not pin.fault[i]])
    sizes, levels = [], []
    solve = circle.solve_circles_rough      # (round 48: every candidate's first solve, a rough one)
    own_levels = circle.CircleBatch.panel_levels
    monkeypatch.setattr(circle.CircleBatch, "panel_levels", lambda law: levels.append(own_levels(law)) or levels[-1])

    def counted(phi, *args):
        sizes.append(np.size(phi))
        return solve(phi, *args)
    monkeypatch.setattr(circle, "solve_circles_rough", counted)
    monkeypatch.setattr(curves, "SOLVE_ROWS", solve_rows)
    got = curves.candidates_curve(pin, rows, strokes, prof)
    monkeypatch.undo()
    return got, sizes, levels


def _same(a, b):
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b))


def test_candidates_solved_in_chunks_are_the_same(monkeypatch):
    """prusa_gyroid_arcs: no arc goes to Newton; its 504 candidates in chunks of 64,
    whose grids have fewer panel levels than the one batch's (its most-levelled laws
    are surely over a limit: not among those whose figures are made), give the tables of
    the one batch: each chunk's figures are made on the whole batch's grid (with the last
    chunk's levels, 56 of its I differ)."""
    whole, one, lv_one = _tables(monkeypatch, "prusa_gyroid_arcs.gcode", 10 ** 9)
    chunked, many, levels = _tables(monkeypatch, "prusa_gyroid_arcs.gcode", 64)
    assert len(one) == 1 and len(many) == -(-one[0] // 64)
    assert levels[-1] < max(levels) == lv_one[0]
    assert np.isfinite(whole[2]).sum() > 100
    assert _same(whole, chunked)


def test_candidates_with_newton_in_chunks_are_the_same(monkeypatch):
    """prusa_concentric: chunks send arcs to Newton, whose steps are each arc's own since
    arcs53 (circle._newton_cheb): the chunks are not solved again in one batch, and the
    tables are the one batch's."""
    whole, one, _ = _tables(monkeypatch, "prusa_concentric.gcode", 10 ** 9)
    n0 = circle.NEWTON_ARCS[0]
    chunked, many, _ = _tables(monkeypatch, "prusa_concentric.gcode", 64)
    assert circle.NEWTON_ARCS[0] > n0
    first = -(-one[0] // 64)
    assert one[0] > 64 and max(many) == 64 and sum(many[:first]) == one[0]   # chunks only
    assert _same(whole, chunked)


if __name__ == "__main__":
    pytest.main([__file__, "-q"])
