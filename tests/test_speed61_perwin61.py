"""The windowed path's per-window costs (issue 8, perwin61):
- plan.PiecesMemo makes the new inputs of its calls together, once make_rows of them wait
  (or at piece()), not a make a call: the same SharedPiece as pieces_once of all the rows,
  bit for bit, whatever the windows and make_rows; inputs whose make raises fail every row
  that has them (their "planning" error), the piece that of the other rows;
- its index of the inputs met (plan._InputsIndex: by a hash of their bits, each found row
  compared) gives the ids a dict of their bytes gives, hashes colliding or not;
- the command, windowed at several windows (37, 2048) and with the memo making its inputs
  a few at a time, writes the list path's file and summary."""
import json
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline, plan_windows
from gcode_opt import plan as plan_mod
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import _plan_kind_codes_of, _rows_by_kind, plan_inputs
from gcode_opt.strokes import K_LINE

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
VOLATILE = ("timing_s", "elapsed_s", "output")


def _line_inputs(name="prusa_mk3s_rectilinear.gcode"):
    prof = load_profile("prusa-mk3s")
    path = SAMPLES / name
    opts = Options(features=feat.default_selection(str(path))[0])
    strokes, _ = analyse(str(path), prof, opts)
    pin = plan_inputs(strokes, prof, opts)
    return pin, _rows_by_kind(strokes, _plan_kind_codes_of(strokes, pin))[K_LINE]


def _same_bits(ref, got):
    assert len(ref) == len(got) == 1 and type(got[0]) is plan_mod.SharedPiece
    for f in plan_mod.SharedPiece._fields:
        a, b = getattr(ref[0], f), getattr(got[0], f)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), f


def _counted(calls):
    def make(p, rows, T_orig):
        calls.append(rows.size)
        return plan_mod.candidate_pieces(p, rows, T_orig)
    return make


@pytest.mark.parametrize("make_rows", [0, 50, 10 ** 9])
def test_memo_makes_waiting_inputs_together(make_rows):
    """8 windows of lines: each make call holds make_rows new inputs at least (but the
    last, at piece()); all of them the rows pieces_once makes, and its SharedPiece."""
    pin, r = _line_inputs()
    calls = []
    ref = plan_mod.pieces_once(_counted(calls), pin.take(r), r, pin.T_orig)
    once = sum(calls)
    assert 0 < once < 0.5 * r.size           # (the sample's lines repeat: the memo has work)
    calls.clear()
    memo = plan_mod.PiecesMemo(make_rows=make_rows)
    for w in np.array_split(r, 8):
        assert memo.add(_counted(calls), pin.take(w), w, pin.T_orig)
    got = memo.piece()
    assert sum(calls) == once
    assert all(n >= make_rows for n in calls[:-1])
    if make_rows == 0:
        assert len(calls) > 2                # (a window of new inputs a call)
    if make_rows > once:
        assert len(calls) == 1               # (all at piece())
    _same_bits(ref, got)
    assert memo.failed == {}


def test_memo_lost_inputs_fail_their_rows():
    """A make that raises on one set of inputs (that of the first row of a class of 2 or
    more lines): every row with those inputs (bit for bit) fails with the planning error,
    wherever its window; the piece is pieces_once's of the other rows."""
    pin, r = _line_inputs()
    cols = np.stack([c[r].view(np.int64) for c in (pin.L, pin.v0, pin.v1, pin.v_cap, pin.a_cap, pin.T_orig,
                                                    pin.t_seg_min)], axis=1)
    _, first, counts = np.unique(cols, axis=0, return_index=True, return_counts=True)
    bad = int(r[np.sort(first[counts >= 3])[0]])
    twins = r[(cols == cols[np.searchsorted(r, bad)]).all(axis=1)]
    assert twins.size >= 3 and twins[0] == bad

    def boom(p, rows, T_orig):
        if np.isin(rows, bad).any():
            raise ValueError("boom")
        return plan_mod.candidate_pieces(p, rows, T_orig)
    failed = {}
    memo = plan_mod.PiecesMemo(failed, make_rows=40)
    for w in np.array_split(r, 6):
        assert memo.add(boom, pin.take(w), w, pin.T_orig)
    got = memo.piece()
    assert failed == {int(i): "error: planning (ValueError)" for i in twins}
    keep = r[~np.isin(r, twins)]
    _same_bits(plan_mod.pieces_once(plan_mod.candidate_pieces, pin.take(keep), keep, pin.T_orig), got)


@pytest.mark.parametrize("collide", [False, True])
def test_inputs_index_ids_as_a_dict_of_their_bytes(monkeypatch, collide):
    """Calls of distinct rows (int64 columns; rows recur across calls, -0.0 and 0.0 as
    bits apart): each row's id that of a dict of the rows' bytes, new ones numbered in the
    order met; with every hash equal (collide) too."""
    if collide:
        monkeypatch.setattr(plan_mod, "_row_hashes", lambda cols: np.zeros(cols[0].shape[0], np.uint64))
    rng = np.random.default_rng(61)
    pool = rng.integers(0, 4, (300, 3))
    pool[:, 2] = np.array([0.0, -0.0, 1.5, 2.0])[pool[:, 2]].view(np.int64)
    pool = np.unique(pool, axis=0)
    index, ref = plan_mod._InputsIndex(), {}
    for _ in range(5):
        rows = pool[rng.permutation(len(pool))[:rng.integers(1, len(pool))]]
        got = index.ids([rows[:, j].copy() for j in range(3)])
        want = [ref.setdefault(r.tobytes(), len(ref)) for r in rows]
        assert got.tolist() == want
        assert len(index) == len(ref)


def _run(monkeypatch, tmp_path, name, window=None):
    if window is None:
        monkeypatch.delenv("GCODE_OPT_WINDOWED", raising=False)
    else:
        monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
        monkeypatch.setenv("GCODE_OPT_WINDOW", str(window))
    out = tmp_path / f"{name}.{window}.gcode"
    s = pipeline.process(str(SAMPLES / name), str(out), load_profile("prusa-mk3s"), pipeline.Options())
    s = json.loads(json.dumps({k: v for k, v in s.items() if k not in VOLATILE}, default=str))
    return out.read_bytes(), s


@pytest.mark.parametrize("window,make_rows,makes", [(37, 16, 2), (37, plan_mod.MEMO_MAKE_ROWS, 1), (2048, 16, 1)])
def test_windowed_writes_the_list_paths_file(monkeypatch, tmp_path, window, make_rows, makes):
    """The rectilinear sample (its lines repeat) windowed, its lines' candidates in calls of
    100 rows or more: the memo's waiting inputs made in several calls where make_rows is
    small; the list path's file and summary."""
    name = "prusa_mk3s_rectilinear.gcode"
    want = _run(monkeypatch, tmp_path, name)
    calls = []
    make = plan_mod.PiecesMemo._make_waiting

    def counted(self):
        calls.append(len(self.waiting))
        return make(self)
    monkeypatch.setattr(plan_mod, "MEMO_MAKE_ROWS", make_rows)
    monkeypatch.setattr(plan_windows, "LINE_ROWS", 100)        # (the lines in several memo calls)
    monkeypatch.setattr(plan_mod.PiecesMemo, "_make_waiting", counted)
    got = _run(monkeypatch, tmp_path, name, window)
    assert sum(1 for n in calls if n) >= makes        # (2048: the sample's strokes in one window)
    assert got[0] == want[0]
    assert got[1] == want[1]
