"""Issue 8, session 59 (mem59): what the windowed command holds and does not read, set aside
in files at the same bits (benchmarks/mem59.md).

- The candidate tables' beta and KE (plan.Candidates.set_aside_weights): the table indexes
  as before, every double the same (numpy's answers for ints, negatives, lists, 2-D, bool
  masks, slices, empty, out of range), across chunks of the file; plan_auto's plan the
  same; the spill keeps them aside; declined where the table cannot be written.
- The chains' memos' rows (stored_strokes.StoredStrokes.set_aside_memos,
  chains.MemosAside): emptied in place through the rewrite, read back into the same
  objects, byte for byte, when a memo is handed out (a window's load, kept_at); a write
  error loses nothing.
- The windowed command, two passes (the second pass reads the memos back), writes the
  list path's bytes."""
import gc
import warnings
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import features as feat
from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import stroke_store
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import T_RATIOS, Candidates, SpilledCandidates, plan_auto
from gcode_opt.plan_windows import planned_strokes
from gcode_opt.profile import load_profile
from gcode_opt.stroke_store import StrokeStore

from windowed_run import run_command

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


def _tables(rng, n, k=len(T_RATIOS)):
    mask = rng.random((n, k)) < 0.3
    m = int(mask.sum())
    vals = rng.normal(size=(4, m))
    vals[1, ::5] = np.inf
    vals[3, ::7] = np.nan
    return Candidates(mask, vals, rng.random(n) < 0.5, rng.random(n) + 0.1)


def _bits(a):
    a = np.asarray(a, float)
    return a.shape, a.tobytes()


def _index_cases(rng, m):
    return [np.arange(m), rng.integers(0, m, 500), rng.integers(0, m, (7, 11)), np.array([m - 1, 0, 0, m - 1]),
            np.array([-1, -m, 3]), [2, 5, 2], rng.random(m) < 0.4, slice(None), slice(3, m - 2, 4), slice(None, None, -1),
            np.zeros(0, np.intp), np.int64(7), -2]


@pytest.mark.parametrize("bits", [0, 3, 13])
def test_weights_aside_index_as_the_table(tmp_path, monkeypatch, bits):
    monkeypatch.setattr(plan_mod._WeightsFile, "CHUNK_BITS", bits)
    rng = np.random.default_rng(59)
    cands = _tables(rng, 100)
    want = cands.vals.copy()
    m = want.shape[1]
    assert cands.set_aside_weights(str(tmp_path))
    got = cands.vals
    assert type(got) is not np.ndarray and got.shape == (4, m) and len(got) == 4
    assert _bits(np.asarray(got)) == _bits(want)
    for f in range(4):
        assert _bits(list(got)[f][np.arange(m)]) == _bits(want[f])
        for idx in _index_cases(rng, m):
            assert _bits(got[f][idx]) == _bits(want[f][idx]), (f, idx)
            assert _bits(got[f, idx]) == _bits(want[f, idx]), (f, idx)
            assert _bits(got[-4 + f][idx]) == _bits(want[-4 + f][idx])
    for idx in _index_cases(rng, m)[:6]:
        assert _bits(got[:, idx]) == _bits(want[:, idx])
    for bad in (np.array([m]), np.array([0, -m - 1])):
        with pytest.raises(IndexError):
            got[1][bad]
    with pytest.raises(IndexError):
        got[4]
    # (what else reads the table: the same answers)
    rows = rng.choice(100, 50, replace=False)
    want_c = _tables(np.random.default_rng(59), 100)
    assert all(_bits(a) == _bits(b) for a, b in zip(cands, want_c))
    assert _bits(cands.at(rows, np.zeros(50, int))[:, cands.cnt[rows] > 0]) == \
        _bits(want_c.at(rows, np.zeros(50, int))[:, want_c.cnt[rows] > 0])
    assert all(_bits(a) == _bits(b) for a, b in zip(cands.allocation_tables(rows, want_c.T_orig[rows], rows + 1.0)[:3],
                                                    want_c.allocation_tables(rows, want_c.T_orig[rows], rows + 1.0)[:3]))


def _planned_sample(name="prusa_gyroid_fullspeed.gcode", prof="bambu-x1c"):
    profile = load_profile(prof)
    path = str(SAMPLES / name)
    opts = Options(features=feat.default_selection(path)[0])
    opts.ringing = False
    strokes, sim0 = analyse(path, profile, opts)
    pin = sc.plan_inputs(strokes, profile, opts)
    budget = opts.max_slowdown_r * sim0.time_t
    sc.plan_strokes(strokes, pin, profile, opts, budget)
    return pin, budget


def _plan_bits(p):
    return [np.asarray(getattr(p, k)).tobytes() for k in ("retime", "T", "beta", "I_law", "KE_law")] + \
        [list(p.reason), float(p.lam).hex()]


def test_plan_auto_the_same_with_weights_aside(tmp_path, monkeypatch):
    """plan_auto on a sample's tables (lines sharing entries, curves, chains), held and set
    aside, with and without its memo, at several budgets; the file read a few entries a
    chunk (CHUNK_BITS 6: 64 entries)."""
    monkeypatch.setattr(plan_mod._WeightsFile, "CHUNK_BITS", 6)
    pin, budget = _planned_sample()
    held = pin.cached[0]
    aside = held.spill(str(tmp_path)).load()
    assert aside.set_aside_weights(str(tmp_path))
    groups = [np.arange(len(pin.T_orig))]
    memo_h, memo_a = {}, {}
    for r in (0.5, 1.0, 1.3):
        want = plan_auto(pin, r * budget, held, groups, memo_h)
        assert _plan_bits(plan_auto(pin, r * budget, aside, groups, memo_a)) == _plan_bits(want)
        assert _plan_bits(plan_auto(pin, r * budget, aside, groups)) == _plan_bits(want)
        assert want.retime.sum() > 100


def test_spill_keeps_the_weights_aside(tmp_path):
    cands = _tables(np.random.default_rng(3), 300)
    want = [np.asarray(getattr(cands, n)).copy() for n in Candidates.SPILLED]
    assert cands.set_aside_weights(str(tmp_path))
    weights = cands.vals.weights
    spilled = cands.spill(str(tmp_path))
    assert type(spilled) is SpilledCandidates and spilled.weights is weights
    back = spilled.load()
    assert type(back.vals) is plan_mod._AsideVals and back.vals.weights is weights and spilled.weights is None
    for name, w in zip(Candidates.SPILLED, want):
        assert _bits(np.asarray(getattr(back, name), float)) == _bits(np.asarray(w, float)), name
    # a spill never loaded: close() closes the weights' file too
    again = back.spill(str(tmp_path))
    fh = again.weights.fh
    again.close()
    assert fh.closed and again.weights is None


def test_weights_aside_declined(tmp_path):
    cands = _tables(np.random.default_rng(4), 50)
    vals = cands.vals
    assert not cands.set_aside_weights(str(tmp_path / "no such folder"))
    assert cands.vals is vals
    cands.vals = np.asfortranarray(vals)
    assert not cands.set_aside_weights(str(tmp_path))
    assert type(cands.vals) is np.ndarray


def test_weights_file_closed_when_collected(tmp_path):
    cands = _tables(np.random.default_rng(5), 50)
    assert cands.set_aside_weights(str(tmp_path))
    fh = cands.vals.weights.fh
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResourceWarning)
        del cands
        gc.collect()
    assert fh.closed


# ---------------------------------------------------------------- the memos' rows

def _stored_planned(folder, name="prusa_gyroid_fullspeed.gcode", prof="bambu-x1c", window=37):
    """(StoredStrokes, pin, profile, opts, budget) of the sample planned as the windowed
    command plans it (a store in a file in folder)."""
    profile = load_profile(prof)
    path = str(SAMPLES / name)
    opts = Options(features=feat.default_selection(path)[0])
    opts.ringing = False
    store = StrokeStore(folder=str(folder))
    _, sim0 = analyse(path, profile, opts, store)
    pin, strokes = planned_strokes(store, profile, opts, window)
    budget = opts.max_slowdown_r * sim0.time_t
    sc.plan_strokes(strokes, pin, profile, opts, budget)
    return strokes, pin, profile, opts, budget


_SLOTS = ("at", "n", "src_i", "seg_T", "seg_beta", "seg_key", "seg", "seg_tin")


def _memos_state(strokes):
    """Each memo of the side table: its row, class, rows array (its object and bytes), the
    objects it shares (kept, src) and its other slots' values."""
    side = strokes._side["chain_T"]
    return [(r, type(m), id(m.figs), None if m.figs is None else m.figs.tobytes(), id(m.kept), id(m.src))
            + tuple(getattr(m, k) for k in _SLOTS) for r, m in enumerate(side) if m is not None]


def test_memos_aside_read_back_the_same(tmp_path):
    strokes, *_ = _stored_planned(tmp_path)
    want = _memos_state(strokes)
    assert len(want) > 100 and sum(len(w[3] or b"") for w in want) > 10000
    figs = {w[2]: m.figs for w, m in zip(want, filter(None, strokes._side["chain_T"]))}
    assert strokes.set_aside_memos(str(tmp_path))
    assert not strokes.set_aside_memos(str(tmp_path))          # (once)
    side = strokes._side["chain_T"]
    assert all(m is None for m in side) and all(len(f) == 0 for f in figs.values())       # (let go)
    rows = np.array([w[0] for w in want[:5]])
    got = strokes.kept_at(rows)["chain_T"]                       # (hands memos out: read back)
    assert [type(m) for m in got] == [chains.ChainMemo] * 5
    assert _memos_state(strokes) == want
    # a window's load reads them back too
    assert strokes.set_aside_memos(str(tmp_path))
    strokes[want[-1][0]]
    assert _memos_state(strokes) == want


def test_memos_held_elsewhere_stay(tmp_path):
    """A memo another object holds is not let go (nor any: a copy would part from it); the
    rows arrays still are."""
    strokes, *_ = _stored_planned(tmp_path)
    want = _memos_state(strokes)
    side = strokes._side["chain_T"]
    held = next(m for m in side if m is not None)
    assert strokes.set_aside_memos(str(tmp_path))
    assert sum(m is not None for m in side) == len(want)
    assert all(m.figs is None or len(m.figs) == 0 for m in side if m is not None)
    strokes.kept_at(np.array([want[0][0]]))
    assert _memos_state(strokes) == want and held in side


def test_memos_with_a_last_plan_stay(tmp_path):
    """A memo that holds a last plan (seg_T ... : the list path's runs keep one) keeps every
    memo an object (making them again would lose it); the rows arrays are still set aside."""
    strokes, *_ = _stored_planned(tmp_path)
    side = strokes._side["chain_T"]
    r0 = next(r for r, m in enumerate(side) if m is not None)
    side[r0].seg_T = 1.5
    want = _memos_state(strokes)
    assert strokes.set_aside_memos(str(tmp_path))
    assert sum(m is not None for m in side) == len(want)
    strokes.kept_at(np.array([r0]))
    assert _memos_state(strokes) == want and side[r0].seg_T == 1.5


def test_memo_rows_aside_write_error_loses_nothing(tmp_path, monkeypatch):
    strokes, *_ = _stored_planned(tmp_path)
    want = _memos_state(strokes)
    calls = []

    def failing(self, pos, data):
        calls.append(pos)
        if len(calls) == 2:
            raise OSError("disk full")
        return real(self, pos, data)

    real = stroke_store._TempFile.write
    monkeypatch.setattr(stroke_store._TempFile, "write", failing)
    assert not strokes.set_aside_memos(str(tmp_path))
    assert len(calls) == 2 and strokes._aside is None
    assert _memos_state(strokes) == want


def test_replan_after_memo_rows_aside_is_the_same(tmp_path):
    """A second plan_strokes (the command's second pass) after the memos' rows were set
    aside: the same plan as with them held."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    strokes, pin, profile, opts, budget = _stored_planned(tmp_path / "a")
    want = sc.plan_strokes(strokes, pin, profile, opts, 0.9 * budget)
    strokes, pin, profile, opts, budget = _stored_planned(tmp_path / "b")
    assert strokes.set_aside_memos(str(tmp_path))
    got = sc.plan_strokes(strokes, pin, profile, opts, 0.9 * budget)
    assert strokes._aside is None
    assert _plan_bits(got) == _plan_bits(want)
    assert [np.asarray(x).tobytes() for x in (got.t_pred, got.a2_pred)] == \
        [np.asarray(x).tobytes() for x in (want.t_pred, want.a2_pred)]


def test_memo_rows_aside_keeps_an_exported_array(tmp_path):
    strokes, *_ = _stored_planned(tmp_path)
    want = _memos_state(strokes)
    figs = next(m.figs for m in strokes._side["chain_T"] if m is not None and m.figs)
    view = memoryview(figs)
    aside = chains.MemosAside(strokes._side["chain_T"], str(tmp_path))
    assert len(figs) and all(f is not figs for f, _, _ in aside._rows)
    view.release()
    aside.restore()
    assert _memos_state(strokes) == want


@pytest.mark.parametrize("name,prof", [("prusa_gyroid_fullspeed.gcode", "bambu-x1c"),
                                       pytest.param("prusa_benchy_like.gcode", "prusa-mk3s", marks=pytest.mark.slow)])
def test_windowed_two_passes_write_the_lists_bytes(tmp_path, monkeypatch, name, prof):
    """Both files take two passes: the second re-plans with the memos' rows read back."""
    seen = []
    real = chains.MemosAside.restore
    monkeypatch.setattr(chains.MemosAside, "restore", lambda self: (seen.append(1), real(self))[1])
    want = run_command(monkeypatch, SAMPLES / name, tmp_path / "a.gcode", False, 0, prof)
    got = run_command(monkeypatch, SAMPLES / name, tmp_path / "b.gcode", True, 64, prof)
    assert want[1]["rewrite_passes"] == 2 and seen
    assert got[0] == want[0]
    assert got[1] == want[1]


def test_of_pieces_makes_a_large_table_on_a_trimmed_heap(monkeypatch):
    """Candidates.of_pieces gives the heap's free pages back (pipeline.trim_heap) before it
    makes a table of TRIM_ENTRIES entries or more, not for a smaller one; the same table."""
    from gcode_opt import pipeline
    trims = []
    monkeypatch.setattr(pipeline, "trim_heap", lambda: trims.append(1))
    rng = np.random.default_rng(8)
    n, k = 60, len(T_RATIOS)
    T_orig = rng.random(n) + 0.1
    sub = np.arange(n)
    tables = [T_orig[:, None] * T_RATIOS[None, :], rng.random((n, k)), np.where(rng.random((n, k)) < 0.4, 1.0, np.inf),
              rng.random((n, k))]
    want, _ = Candidates.of_pieces(n, [Candidates.piece(sub, tables, T_orig)], T_orig)
    m = want.vals.shape[1]
    assert trims == []
    monkeypatch.setattr(plan_mod, "TRIM_ENTRIES", m + 1)
    Candidates.of_pieces(n, [Candidates.piece(sub, tables, T_orig)], T_orig)
    assert trims == []
    monkeypatch.setattr(plan_mod, "TRIM_ENTRIES", m)
    got, _ = Candidates.of_pieces(n, [Candidates.piece(sub, tables, T_orig)], T_orig)
    assert trims == [1]
    assert all(_bits(a) == _bits(b) for a, b in zip(got, want))
