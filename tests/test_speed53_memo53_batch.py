"""The windowed candidates make the chains of consecutive windows in one call
(schedule._WaitingChains, chain_batch chains a call): the tables are one call's bit for bit,
and every chain's memo holds the same candidates (predicted time, law T, beta, and the
kept law's knots and figures, bit for bit) as after one call of every stroke -- over a list
and over a StoredStrokes whose windows are let go before their chains' call (the memos are
its side table's objects)."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.stored_strokes import StoredStrokes, curve_geometry, join_plan_inputs
from gcode_opt.stroke_store import StrokeStore
from gcode_opt.strokes import K_CHAIN

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


def _setup(name, store=None):
    prof = load_profile("prusa-mk3s")
    path = str(SAMPLES / name)
    opts = Options(features=feat.default_selection(path)[0])
    strokes, _ = analyse(path, prof, opts, store) if store is not None else analyse(path, prof, opts)
    return prof, opts, strokes


def _entries(c):
    """Every row's (cnt, t_pos, its entries' columns and values) in row order, as bytes."""
    cnt = c.cnt
    at = np.repeat(c.first - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    return [np.ascontiguousarray(a).tobytes() for a in (cnt, c.t_pos, c.col[at], c.vals[:, at])]


def _memo_bits(st, profile):
    """A chain's memo rows, newest first: (t_pred, law T, beta) and its kept law's row
    (knot speeds, durations, predicted time and ∫a²) as bits; not the row's place in its
    batch (the batches differ)."""
    out = []
    for t, T, beta, r, kept in st.chain_T.rows():
        vk, dt, tp, a2 = kept.row(int(r), st)
        out.append((t.hex(), T.hex(), beta.hex(), np.asarray(vk, float).tobytes(), np.asarray(dt, float).tobytes(),
                    float(tp).hex(), float(a2).hex()))
    return out


def _counting(monkeypatch):
    calls = []
    make = sc.KINDS[K_CHAIN].candidates

    def counted(pin, rows, *a, **k):
        calls.append(len(rows))
        return make(pin, rows, *a, **k)
    monkeypatch.setattr(sc.KINDS[K_CHAIN], "candidates", counted)
    return calls


_REF = {}


def _reference(name):
    """One call's tables and every chain's memo bits {row: bits}."""
    if name not in _REF:
        prof, opts, strokes = _setup(name)
        pin = sc.plan_inputs(strokes, prof, opts)
        rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
        cands, _ = sc._candidates(strokes, pin, prof, opts, rows, sc._faults_of(pin.fault))
        chain_rows = rows[K_CHAIN].tolist()
        _REF[name] = (_entries(cands), {i: _memo_bits(strokes[i], prof) for i in chain_rows})
    return _REF[name]


@pytest.mark.parametrize("K,batch", [(64, 1), (64, 25), (64, 100), (16, None)])
def test_chain_batches_over_a_list(monkeypatch, K, batch):
    tables, memos = _reference("prusa_gyroid_fullspeed.gcode")
    calls = _counting(monkeypatch)
    prof, opts, strokes = _setup("prusa_gyroid_fullspeed.gcode")
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
    bounds = np.linspace(0, len(strokes), K + 1).astype(int)
    cands, _ = sc.candidates_in_windows(strokes, pin, prof, opts, rows, sc._faults_of(pin.fault), bounds,
                                        chain_batch=batch)
    assert _entries(cands) == tables
    assert {i: _memo_bits(strokes[i], prof) for i in memos} == memos
    # the calls: a window's chains join the waiting ones; a call once `batch` wait or at the end
    n = rows[K_CHAIN].size
    assert sum(calls) == n and len(memos) == n > 100
    per_window = [int(((rows[K_CHAIN] >= lo) & (rows[K_CHAIN] < hi)).sum()) for lo, hi in zip(bounds[:-1], bounds[1:])]
    want, wait = [], 0
    for c in per_window:
        wait += c
        if wait >= (sc.CHAIN_BATCH if batch is None else batch):
            want.append(wait)
            wait = 0
    assert calls == want + ([wait] if wait else [])
    assert len(calls) < sum(c > 0 for c in per_window) or batch == 1


def test_chain_batches_over_stored_strokes(monkeypatch):
    """Windows of 37 strokes, one held: a batch of 60 chains spans windows let go (and loaded
    again) before its call; each chain's memo read back through the store is the list's."""
    tables, memos = _reference("prusa_gyroid_fullspeed.gcode")
    calls = _counting(monkeypatch)
    window = 37
    store = StrokeStore(in_memory=True)
    prof, opts, store = _setup("prusa_gyroid_fullspeed.gcode", store)
    parts = []
    for lo in range(0, len(store), window):
        sts = store.load(lo, lo + window)
        parts.append(sc.plan_inputs(sts, prof, opts))
        store.rewrite(np.arange(lo, lo + len(sts), dtype=np.int64), sts)
    pin = join_plan_inputs(parts)
    strokes = StoredStrokes(store, window, held=1, on_load=curve_geometry(pin.plan_kind_codes, prof),
                            keep=("chain_T",))
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
    cands, _ = sc.candidates_in_windows(strokes, pin, prof, opts, rows, sc._faults_of(pin.fault), strokes.bounds(),
                                        chain_batch=60)
    assert _entries(cands) == tables
    assert max(calls) >= 60 and len(calls) < len(memos) // 30
    assert {i: _memo_bits(strokes[i], prof) for i in memos} == memos
    store.close()

