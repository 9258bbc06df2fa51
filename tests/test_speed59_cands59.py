"""The windowed candidates read a window's arcs, curves and chains as strokes made of their
records alone where those are few of its rows (StoredStrokes.take, schedule._window_strokes,
benchmarks/cands59.md), not the window loaded: the candidate tables are the list path's
one call's bit for bit, every chain's memo read back through the store holds the list's
candidates, the curve geometry is the kept one given back (none made again), and the
command writes the list path's bytes.  Run compiled and with GCODE_OPT_PURE_PYTHON=1."""
import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import schedule as sc
from gcode_opt import stored_strokes
from gcode_opt.geom_keep import GeomKeep
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan_windows import planned_strokes
from gcode_opt.profile import load_profile
from gcode_opt.stroke_store import StrokeStore
from gcode_opt.strokes import K_CHAIN, K_LINE

from test_speed50_wina50_windows import CORPUS, SAMPLES, _assert_same
from test_speed53_memo53_batch import _memo_bits
from windowed_run import run_command

WINDOW = 37


_LIST = {}


def _list_path(name):
    """The list path's one call: (Candidates, failed, rows by kind, {chain row: memo bits}, n)."""
    if name not in _LIST:
        _LIST[name] = _one_call(name)
    cands, failed, rows, memos, n = _LIST[name]
    return cands, dict(failed), rows, memos, n


def _list_tables(path):
    """The list path's one candidates call on the file at path (prusa-mk3s, its default
    features): (strokes, rows by kind, failed, Candidates, profile, options)."""
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(path)[0])
    strokes, _ = analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
    failed = sc._faults_of(pin.fault)
    cands, _ = sc._candidates(strokes, pin, prof, opts, rows, failed)
    return strokes, rows, failed, cands, prof, opts


def _one_call(name):
    strokes, rows, failed, cands, prof, _ = _list_tables(str(SAMPLES / name))
    memos = {i: _memo_bits(strokes[i], prof) for i in rows[K_CHAIN].tolist()}
    return cands, failed, rows, memos, len(strokes)


class _Counts:
    """The windows taken (StoredStrokes.take) and the rows given kept geometry (GeomKeep.give)."""

    def __init__(self, monkeypatch):
        self.taken, self.given = [], 0
        take, give = stored_strokes.StoredStrokes.take, GeomKeep.give

        def counted_take(strokes, rows):
            self.taken.append(rows.size)
            return take(strokes, rows)

        def counted_give(keep, rows, sts, kappa=False):
            self.given += len(rows)
            return give(keep, rows, sts, kappa)
        monkeypatch.setattr(stored_strokes.StoredStrokes, "take", counted_take)
        monkeypatch.setattr(GeomKeep, "give", counted_give)


def _windowed(tmp_path, monkeypatch, name, take_r):
    """planned_strokes over a store in a file (windows of WINDOW strokes, TAKE_UNDER_R
    take_r): (Candidates, failed, the StoredStrokes, the windows it loaded in the
    candidates, _Counts)."""
    monkeypatch.setattr(sc, "TAKE_UNDER_R", take_r)
    prof = load_profile("prusa-mk3s")
    path = str(SAMPLES / name)
    opts = Options(features=feat.default_selection(path)[0])
    store = StrokeStore(folder=str(tmp_path))
    analyse(path, prof, opts, store)
    counts = _Counts(monkeypatch)
    pin, strokes = planned_strokes(store, prof, opts, WINDOW)
    cands, _, failed = pin.cached
    return cands, failed, strokes, strokes.loads, counts


@pytest.mark.parametrize("name", ["prusa_gyroid_fullspeed.gcode",     # chains (batches over windows)
                                  "prusa_gyroid.gcode",               # curves
                                  "prusa_gyroid_arcs.gcode"])         # arcs (windows made again)
def test_taken_windows_give_the_list_paths_tables_and_memos(tmp_path, monkeypatch, name):
    ref, failed_ref, rows, memos, n = _list_path(name)
    cands, failed, strokes, loads, counts = _windowed(tmp_path, monkeypatch, name, 2.0)    # every window taken
    _assert_same(ref, cands, n)
    assert failed == failed_ref
    # no window loaded: each window holding an arc, a curve or a chain taken (once, its
    # windows made again once more), each taken row's geometry the kept one given back
    read = np.concatenate([r for k, r in rows.items() if k != K_LINE])
    assert loads == 0 and len(counts.taken) >= np.unique(read // WINDOW).size > 1
    assert sum(counts.taken) >= read.size and counts.given >= read.size
    # the chains' memos kept in the side table: a later load gives back what the call wrote
    assert {i: _memo_bits(strokes[i], load_profile("prusa-mk3s")) for i in memos} == memos
    strokes.store.close()


def test_windows_taken_or_loaded_by_their_share(tmp_path, monkeypatch):
    """At the default share some windows of the chains' sample are taken, the others loaded
    (their arcs, curves and chains at least half their rows): the same tables and memos."""
    name = "prusa_gyroid_fullspeed.gcode"
    ref, failed_ref, rows, memos, n = _list_path(name)
    cands, failed, strokes, loads, counts = _windowed(tmp_path, monkeypatch, name, sc.TAKE_UNDER_R)
    _assert_same(ref, cands, n)
    assert failed == failed_ref
    assert loads > 0 and counts.taken
    assert {i: _memo_bits(strokes[i], load_profile("prusa-mk3s")) for i in memos} == memos
    strokes.store.close()


@pytest.mark.parametrize("name", ["prusa_gyroid_fullspeed.gcode", "prusa_gyroid_arcs.gcode"])
def test_command_with_taken_windows_writes_the_list_paths_bytes(tmp_path, monkeypatch, name):
    ref = run_command(monkeypatch, SAMPLES / name, tmp_path / "list.gcode", False, None)
    monkeypatch.setattr(sc, "TAKE_UNDER_R", 2.0)
    got = run_command(monkeypatch, SAMPLES / name, tmp_path / "win.gcode", True, WINDOW)
    assert got[0] == ref[0]
    assert got[1] == ref[1]


@pytest.mark.slow
@pytest.mark.skipif(not (CORPUS / "plate_rectilinear.gcode").exists(), reason="corpus plate not here")
@pytest.mark.parametrize("plate", ["plate_rectilinear.gcode", "plate_gyroid.gcode"])
def test_plates_windowed_tables_are_the_list_paths(tmp_path, monkeypatch, plate):
    """The plates at the pipeline's window (the rectilinear plate's windows taken, ~70 arcs,
    curves and chains of 1024 strokes; most of the gyroid plate's loaded): one call's tables."""
    from gcode_opt.plan_windows import WINDOW as window
    path = str(CORPUS / plate)
    strokes, _, failed_ref, ref, prof, opts = _list_tables(path)
    n = len(strokes)
    del strokes
    store = StrokeStore(folder=str(tmp_path))
    analyse(path, prof, opts, store)
    counts = _Counts(monkeypatch)
    pin, got = planned_strokes(store, prof, opts, window)
    _assert_same(ref, pin.cached[0], n)
    assert pin.cached[2] == failed_ref
    assert counts.taken
    store.close()
