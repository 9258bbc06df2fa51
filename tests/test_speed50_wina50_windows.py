"""Candidate tables made a window of strokes at a time (schedule.candidates_in_windows) are
the same bits as one call of every stroke (schedule._candidates): every stroke's count of
feasible entries, their columns, t_pos and the four values (T, beta, I, KE), bit for bit,
and the same failed strokes.  Each configuration gets a fresh analyse + plan_inputs (the
chains keep their memos on the strokes while making candidates).  The pieces that make it
so: the curves' grid levels decided for the file (curves.curve_grid_levels; the retries'
windows made again where they fall short), the lines' distinct inputs made once across
calls (plan.PiecesMemo)."""
import os
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import features as feat
from gcode_opt import plan as plan_mod
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import (_candidates, _faults_of, _plan_kind_codes_of, _rows_by_kind, candidates_in_windows,
                                plan_inputs)
from gcode_opt.strokes import K_CURVE, K_LINE

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
CORPUS = Path(os.path.expanduser("~/.cache/gcode-opt-corpus"))


def _setup(path):
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(str(path))[0])
    strokes, _ = analyse(str(path), prof, opts)
    pin = plan_inputs(strokes, prof, opts)
    rows = _rows_by_kind(strokes, _plan_kind_codes_of(strokes, pin))
    return prof, opts, strokes, pin, rows


def _one_call(path):
    prof, opts, strokes, pin, rows = _setup(path)
    failed = _faults_of(pin.fault)
    cands, _ = _candidates(strokes, pin, prof, opts, rows, failed)
    return cands, failed, rows, len(strokes)


def _windows(path, bounds_of, decide_first=False):
    """(Candidates, failed, info) of candidates_in_windows over bounds_of(n, rows)."""
    prof, opts, strokes, pin, rows = _setup(path)
    failed = _faults_of(pin.fault)
    info = {}
    cands, nonfinite = candidates_in_windows(strokes, pin, prof, opts, rows, failed,
                                             bounds_of(len(strokes), rows), info, decide_first)
    for i in nonfinite:                     # (as _candidates records them)
        failed.setdefault(int(i), "error: planning (non-finite)")
    return cands, failed, info


def _entries(c, n):
    """Every row's (cnt, t_pos, col of its entries, vals of its entries), rows in order."""
    cnt = c.cnt
    at = np.repeat(c.first - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    assert cnt.size == n
    return cnt, c.t_pos, c.col[at], c.vals[:, at]


def _assert_same(ref, got, n):
    a, b = _entries(ref, n), _entries(got, n)
    for x, y in zip(a[:3], b[:3]):
        np.testing.assert_array_equal(x, y)
    assert a[3].shape == b[3].shape
    assert a[3].tobytes() == b[3].tobytes()        # bit for bit (NaN, -0.0 included)


def _even(K):
    return lambda n, rows: np.linspace(0, n, K + 1).astype(int)


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode",
                                  "prusa_gyroid_fullspeed.gcode", "prusa_klipper.gcode", "cura_box.gcode"])
def test_windows_same_bits_samples(name):
    ref, failed_ref, rows, n = _one_call(SAMPLES / name)
    for K, decide in ((1, False), (2, True), (8, False), (32, False), (32, True)):
        got, failed, info = _windows(SAMPLES / name, _even(K), decide)
        _assert_same(ref, got, n)
        assert failed == failed_ref
        assert info["newton"] == 0          # (not covered: Newton's batches)


def test_windows_first_pass_made_again():
    """The benchy-like sample's curves take levels 4 to 10, the largest late in the file:
    windows before it are made again (decide_first False), or take the file's levels
    from curve_grid_levels (no window made again).  (Newton solves a few of its arcs, in
    batches that hold the same arcs here.)"""
    path = SAMPLES / "prusa_benchy_like.gcode"
    ref, failed_ref, rows, n = _one_call(path)
    redone = {}
    for K in (2, 8, 32):
        for decide in (False, True):
            got, failed, info = _windows(path, _even(K), decide)
            _assert_same(ref, got, n)
            assert failed == failed_ref
            assert info["levels"][0] == 10
            redone[K, decide] = info["redone"]
    assert redone[8, False] > 0 and redone[32, False] > 0
    assert not any(redone[K, True] for K in (2, 8, 32))


def test_windows_one_curve_each():
    """A window at every curve stroke: each curve batch alone."""
    path = SAMPLES / "prusa_gyroid.gcode"
    ref, failed_ref, rows, n = _one_call(path)
    got, failed, info = _windows(path, lambda n, rows: np.unique(np.concatenate([[0, n], rows[K_CURVE]])))
    _assert_same(ref, got, n)
    assert failed == failed_ref
    # the first pass's levels: the file's, the largest any window's own first pass took
    assert info["levels"][0] == max(o[0][0] for o in info["own"] if o) > 0


def test_windows_retries_made_again(monkeypatch):
    """The retries' levels are known once every window's first pass has run: a window whose
    retries made figures on fewer levels than the file's is made again.  No probe rejects
    a law here (PROBE_MARGIN_R huge, for both runs), so the retries make figures, at
    levels 3..8 by window."""
    monkeypatch.setattr(curves, "PROBE_MARGIN_R", 1e9)
    path = SAMPLES / "prusa_gyroid.gcode"
    ref, failed_ref, rows, n = _one_call(path)
    got, failed, info = _windows(path, lambda n, rows: np.unique(np.concatenate([[0, n], rows[K_CURVE]])))
    retries = [o[1] for o in info["own"] if len(o) > 1 and o[1][1]]
    assert len({lv for lv, _ in retries}) > 1 and info["redone"] > 0
    every = [lv() if callable(lv) else lv for lv, _ in (o[1] for o in info["own"] if len(o) > 1)]
    assert info["levels"][1] == max(every) >= max(lv for lv, _ in retries)
    # the file's: those of one call's retries
    prof, opts, strokes, pin, rows = _setup(path)
    own = []
    curves.candidates_curve(pin, rows[K_CURVE], strokes, prof, None, own)
    assert info["levels"] == (own[0][0], own[1][0])
    _assert_same(ref, got, n)
    assert failed == failed_ref


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_gyroid_fullspeed.gcode"])
def test_curve_grid_levels_is_the_first_pass(name):
    """curve_grid_levels (no law solved) is the level candidates_curve's first pass takes
    from its solves (the rough laws' panel levels), and floors at a call's own levels leave
    its tables as they are."""
    prof, opts, strokes, pin, rows = _setup(SAMPLES / name)
    r = rows[K_CURVE]
    own = []
    table = curves.candidates_curve(pin, r, strokes, prof, None, own)
    assert curves.curve_grid_levels(pin, r, strokes, prof) == own[0][0] > 0
    for lo, hi in ((0, r.size // 3), (r.size // 3, r.size)):      # and of a part: its own
        part = []
        curves.candidates_curve(pin, r[lo:hi], strokes, prof, None, part)
        assert curves.curve_grid_levels(pin, r[lo:hi], strokes, prof) == part[0][0]
    again = curves.candidates_curve(pin, r, strokes, prof, tuple(lv for lv, _ in own))
    for x, y in zip(table, again):
        assert np.asarray(x).tobytes() == np.asarray(y).tobytes()


def _line_inputs(name):
    prof, opts, strokes, pin, rows = _setup(SAMPLES / name)
    return pin, rows[K_LINE]


def test_pieces_memo_makes_each_input_once():
    """K windows of lines through one PiecesMemo make as many rows as pieces_once of all
    of them, and give its SharedPiece, field for field."""
    pin, r = _line_inputs("prusa_mk3s_rectilinear.gcode")
    made = []

    def make(p, rows, T_orig):
        made.append(rows.size)
        return plan_mod.candidate_pieces(p, rows, T_orig)

    ref = plan_mod.pieces_once(make, pin.take(r), r, pin.T_orig)
    assert len(ref) == 1 and type(ref[0]) is plan_mod.SharedPiece
    once = sum(made)
    assert once < 0.5 * r.size
    for K in (1, 2, 8, 32):
        made.clear()
        memo = plan_mod.PiecesMemo()
        for w in np.array_split(r, K):
            assert memo.add(make, pin.take(w), w, pin.T_orig)
        got = memo.piece()
        assert sum(made) == once
        assert len(got) == 1
        for f in plan_mod.SharedPiece._fields:
            a, b = getattr(ref[0], f), getattr(got[0], f)
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), f


def test_pieces_memo_declines_inputs_not_plain():
    """Rows whose inputs are not plain (a NaN length) are not taken (the caller makes
    them).  (A make that raises: tests/test_speed61_perwin61.py, the memo isolates it.)"""
    pin, r = _line_inputs("prusa_gyroid.gcode")
    memo = plan_mod.PiecesMemo()
    a, b = r[:50], r[50:120]
    assert memo.add(plan_mod.candidate_pieces, pin.take(a), a, pin.T_orig)
    known = len(memo.index)
    bad = pin.take(b)
    bad.L = bad.L.copy()
    bad.L[3] = np.nan
    assert not memo.add(plan_mod.candidate_pieces, bad, b, pin.T_orig)
    assert len(memo.index) == known and len(memo.rows) == 1


@pytest.mark.slow
@pytest.mark.parametrize("name", ["plate_rectilinear.gcode", "plate_gyroid.gcode"])
def test_windows_same_bits_plates(name):
    path = CORPUS / name
    if not path.exists():
        pytest.skip("corpus plate not present")
    ref, failed_ref, rows, n = _one_call(path)
    for K, decide in ((1, False), (2, False), (8, True), (32, False)):
        got, failed, info = _windows(path, _even(K), decide)
        _assert_same(ref, got, n)
        assert failed == failed_ref
