"""The windowed rewrite's plans read back from the runs' spills (issue 8, out57): the records of
a read are made plans by one map for all their blocks (spill_file.block_plans), the chains'
records of a run's blocks are written with their heads made in one pass
(schedule._blocks_records), the chains' records a few doubles apart are read in one pread
(schedule.CHAIN_GAP), and the lines' read-back puts and takes its lists in compiled passes.
Here: the plans read back are record_plans' of each block bit for bit (type, arrays, figures,
verdict, shape) on records of every kind; a run's chain records are the records its plans make
one by one (compiled fields or not); near records are read in one pread and far ones apart,
the same plans either way; the lines' read-back is the same without the compiled passes; and
the windowed command writes the list path's bytes."""
import os

import numpy as np
import pytest

from gcode_opt import line_spill as ls
from gcode_opt import schedule as sc
from gcode_opt import spill_file as sf
from gcode_opt.segments import RowPlan

from windowed_run import run_command

from test_speed52_runs52_windows import seg_bits
from test_speed53_plans53_lazy import SAMPLES
from test_speed55_chain_spill import _plans_of_kinds as _chain_kinds, _timed_chains
from test_speed56_lines56_spill import _keys as _line_keys, _plans_of_kinds as _line_kinds


def _bits(p):
    """A plan's type, arrays and figures (seg_bits), verdict and shape, bit for bit."""
    return None if p is None else (type(p).__name__,) + seg_bits(p) + (p.fault, p.shape)


def _all_records(spill, at, nseg):
    """(the spill's file as doubles, the records' starts, their segment counts) of the records at at."""
    buf = np.frombuffer(os.pread(spill.fh.fileno(), spill.end * 8, 0), float)
    return buf, np.asarray(at, np.int64), np.asarray(nseg, np.int64)


def _each_block(buf, start, blocks, head, cols, shapes):
    """The reference: record_plans of each block, put at its records' places."""
    out = [None] * start.size
    for g, G, n in blocks:
        for q, p in zip(g.tolist(), sf.record_plans(G, n, head, cols, shapes)):
            out[q] = p
    return out


def _many_chain_plans():
    """The chain kinds (RowPlans of a block, SegmentPlans, a faulty one; a trapezoid and a
    junction command the records leave out) three times over: blocks of odd and plain records."""
    plans = []
    for _ in range(3):
        kinds = _chain_kinds()
        sc.seg_fault(kinds[0])
        plans += kinds
    return plans


def test_chain_records_read_back_as_record_plans_of_each_block():
    plans = _many_chain_plans()
    spill = sc._ChainSpill.make(len(plans) + 5)
    rows = np.arange(len(plans)) + 2
    T, beta = np.linspace(1.0, 2.0, rows.size), np.linspace(0.1, 0.2, rows.size)
    spill.put(rows, T, beta, plans)
    held = rows[spill.at[rows] >= 0]
    buf, start, ns = _all_records(spill, spill.at[held], spill.nseg[held])
    blocks = sc._record_blocks(buf, start, ns)
    cols = (2, 3, 4, 5, None)
    got = sf.block_plans(buf, start, blocks, sc._SPILL_HEAD, cols)
    want = _each_block(buf, start, blocks, sc._SPILL_HEAD, cols, ("law",))
    assert len(got) == held.size > 10
    assert [_bits(p) for p in got] == [_bits(p) for p in want]
    assert {type(p).__name__ for p in got} == {"RowPlan", "SegmentPlan"}
    assert {p.fault for p in got} == {"", None}
    # the rows' read-back (take) is the same plans, in rows' order
    took, back, rest = spill.take(rows, T, beta)
    assert took.tolist() == held.tolist() and [_bits(p) for p in back] == [_bits(p) for p in want]
    spill.close()


def _plain_rows(m=4, n=5):
    """m RowPlans of the law of one block of n segments (no other kind of their segment count)."""
    rng = np.random.default_rng(57)
    S = np.cumsum(rng.random((m, n + 1)), axis=1)
    V, A, F = rng.random((m, n + 1)), rng.random((m, n)) + 1.0, rng.random((m, n)) + 1.0
    return [RowPlan(S, V, A, F, i, 1.5 + i, 2.5 + i) for i in range(m)]


def test_line_records_read_back_as_record_plans_of_each_block():
    plain = _plain_rows()
    plans = _line_kinds() * 3 + plain
    cls, T, beta = (np.tile(x, 3) for x in _line_keys())
    cls = cls + np.repeat(np.arange(3), cls.size // 3) * 1000       # (three keys a kind: records apart)
    m = len(plain)
    cls, T, beta = np.r_[cls, 5000 + np.arange(m)], np.r_[T, np.linspace(3.0, 4.0, m)], np.r_[beta, np.full(m, 0.3)]
    spill = ls.LineSpill.make()
    sc.seg_fault(plans[0])
    plain[1].fault = ""
    spill.put(plans, cls, T, beta)
    o = np.argsort(spill.at)
    buf, start, ns = _all_records(spill, spill.at[o], spill.nseg[o])
    blocks = ls._blocks(buf, start, ns)
    cols = (3, 4, 5, 6, 7)
    got = ls._plans(buf, start, blocks)
    want = _each_block(buf, start, blocks, ls.HEAD, cols, ls._SHAPES)
    assert len(got) == start.size > 10
    assert [_bits(p) for p in got] == [_bits(p) for p in want]
    assert {p.shape for p in got} == {"law", "trapezoid"} and {p.fault for p in got} == {"", None}
    spill.close()


def _no_compiled_fields(monkeypatch, *mods):
    """objfields' compiled reads, puts and takes answering "not built" (the pure path's)."""
    for mod in mods:
        monkeypatch.setattr(mod.objfields, "floats", lambda *a, **k: None)
        monkeypatch.setattr(mod.objfields, "codes", lambda *a, **k: None)
        monkeypatch.setattr(mod.objfields, "put_at", lambda *a, **k: False)
        monkeypatch.setattr(mod.objfields, "take", lambda *a, **k: None)


def _records_by_row(spill, rows):
    """Each row's record (bytes), read by its index."""
    out = []
    for r in rows.tolist():
        a, n = int(spill.at[r]), int(spill.nseg[r])
        out.append(os.pread(spill.fh.fileno(), sc._spill_len(n) * 8, a * 8) if a >= 0 else None)
    return out


@pytest.fixture(scope="module")
def run_chains():
    """A real sample's re-timed chains (prusa_gyroid_fullspeed windowed at 37) and the plans a
    run makes of them (RowPlans of finishing blocks): (rows, T, beta, plans, rows of the plan)."""
    strokes, store, prof, rules, plan, rows = _timed_chains()
    with store:
        plans = sc._chain_plans(strokes, plan, rules, prof, rows)
    return rows, plan.T[rows], plan.beta[rows], plans, plan.retime.size


@pytest.mark.parametrize("compiled", [True, False])
def test_run_chain_records_are_the_one_by_one_records(compiled, run_chains, monkeypatch):
    """A run's chain plans written by their blocks are, row by row, the records written plan
    by plan (_spill_arrays' path)."""
    rows, T, beta, plans, n = run_chains
    if not compiled:
        _no_compiled_fields(monkeypatch, sc)
    by_blocks = sc._ChainSpill.make(n)
    by_blocks.put(rows, T, beta, plans)
    assert len(sc._row_plan_blocks(plans)[0]) > 3           # (the block path ran)
    one_by_one = sc._ChainSpill.make(n)
    monkeypatch.setattr(sc, "_row_plan_blocks", lambda ps: ([], [q for q, p in enumerate(ps) if p is not None]))
    one_by_one.put(rows, T, beta, plans)
    want = _records_by_row(one_by_one, rows)
    assert sum(w is not None for w in want) > 50
    assert _records_by_row(by_blocks, rows) == want
    by_blocks.close()
    one_by_one.close()


def _preads(monkeypatch):
    """The reads the spill makes, counted (one entry a call, its size): os.pread, and
    preadv where read_runs reads each run into its place in one array (spill_file._PREADV)."""
    calls = []
    pread = os.pread
    monkeypatch.setattr(sf.os, "pread", lambda fd, n, at: calls.append(n) or pread(fd, n, at))
    if sf._PREADV is not None:
        preadv = sf._PREADV
        monkeypatch.setattr(sf, "_PREADV", lambda fd, bufs, at: calls.append(sum(map(len, bufs))) or preadv(fd, bufs, at))
    return calls


def test_near_chain_records_read_in_one_pread(monkeypatch):
    plans = _many_chain_plans()
    n = len(plans)
    spill = sc._ChainSpill.make(n)
    rows = np.arange(n)
    T, beta = np.linspace(1.0, 2.0, n), np.linspace(0.1, 0.2, n)
    spill.put(rows, T, beta, plans)
    held = rows[spill.at >= 0]
    ask = np.sort(held[np.argsort(spill.at[held])][::2])      # (every other record in the file: gaps of one)
    calls = _preads(monkeypatch)
    got, near, _ = spill.take(ask, T[ask], beta[ask])
    assert got.tolist() == ask.tolist() and len(calls) == 1
    monkeypatch.setattr(sc, "CHAIN_GAP", 0)
    calls.clear()
    got, apart, _ = spill.take(ask, T[ask], beta[ask])
    assert got.tolist() == ask.tolist() and len(calls) == ask.size
    assert [_bits(p) for p in near] == [_bits(p) for p in apart]
    spill.close()


def test_line_take_same_without_compiled_lists(monkeypatch):
    """The lines' read-back (the call before's plans put back, the rows' plans taken) gives the
    same plans, shared the same way, without the compiled puts and takes."""
    def takes():
        plans = _line_kinds()
        spill = ls.LineSpill.make()
        cls, T, beta = _line_keys()
        spill.put(plans, cls, T, beta)
        out = []
        for rows in (np.arange(6), np.arange(2, 9), np.array([0, 1, 2, 3])):
            got, back, rest = spill.take(rows, cls[rows], T[rows], beta[rows])
            ids = {}
            out.append((got.tolist(), rest.tolist(), [_bits(p) for p in back],
                        [ids.setdefault(id(p), len(ids)) for p in back]))
        spill.close()
        return out
    want = takes()
    _no_compiled_fields(monkeypatch, ls)
    assert takes() == want


def test_windowed_command_writes_the_list_paths_bytes(monkeypatch, tmp_path):
    """prusa_gyroid (chains and lines) windowed at 64: the list path's file and summary, its
    rewrite's plans read back (no chain planned after plan_strokes)."""
    reads = []
    take = sc._ChainSpill.take
    monkeypatch.setattr(sc._ChainSpill, "take", lambda self, *a: reads.append(1) or take(self, *a))

    def run(windowed):
        return run_command(monkeypatch, os.path.join(SAMPLES, "prusa_gyroid.gcode"),
                           tmp_path / f"out{windowed}.gcode", windowed, 64)
    want = run(False)
    got = run(True)
    assert reads and got[0] == want[0] and got[1] == want[1]


@pytest.mark.parametrize("compiled", [True, False])
def test_rows_without_a_plan_told_by_their_class(compiled, monkeypatch):
    """_PlansAgain's rows still to plan: the Nones among the rows' plans (compiled pass or not)."""
    if not compiled:
        _no_compiled_fields(monkeypatch, sc)
    plans = _chain_kinds() + [None, 0.0, "", False] + _line_kinds()
    assert sc._are_none(plans).tolist() == [p is None for p in plans]

