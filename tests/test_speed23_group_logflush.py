"""analyse's RecordLog summed a prefix at a time during the pass (pipeline._LogSums.flush,
the log dropping the records summed: issue 8, s23) must give what analyse's per-record
Python path (on_line/apply, no RecordLog: an independent reading of the same records)
gives, bit for bit: every stroke's v0, v1, time, int a^2, int v^2, and the feature tally
in the same order.  Flushes are forced often (LOG_FLUSH_ROWS down to 1 record) so that
strokes, runs still open and features straddle the cuts.  And the log's new pieces
(below, drop, feature_sums' stop, last) against a plain Python reading of random records."""
import os
import random
import struct

import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile

SAMPLES = "sample_gcode/"
_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")
pytestmark = pytest.mark.skipif(fwsim.CORE != "c" or not hasattr(fwsim._core, "RecordLog"),
                                reason="the compiled firmware model is not in use here")

_KEYS = ("first_idx", "last_idx", "v0", "v1", "time_t", "int_a2", "int_v2")


def _bits(x):
    if isinstance(x, float):
        return struct.pack("<d", x)
    if isinstance(x, (list, tuple)):
        return tuple(_bits(y) for y in x)
    return x


def _analyse(path, prof, use_log, flush_rows=None, **kw):
    """analyse with the RecordLog (flushed every flush_rows records) or the per-record
    Python path; the flushes seen: [(log rows before, after)]."""
    saved, saved_rows, saved_flush = pl._record_log, pl.LOG_FLUSH_ROWS, pl._LogSums.flush
    seen = []

    def flush(self, open_line):
        n = self.log.rows
        saved_flush(self, open_line)
        seen.append((n, self.log.rows))
    if not use_log:
        pl._record_log = lambda: None
    if flush_rows is not None:
        pl.LOG_FLUSH_ROWS = flush_rows
    pl._LogSums.flush = flush
    try:
        o = pl.Options(**kw)
        strokes, res = pl.analyse(path, load_profile(prof), o)
    finally:
        pl._record_log, pl.LOG_FLUSH_ROWS, pl._LogSums.flush = saved, saved_rows, saved_flush
    return strokes, res, o, seen


def _same(path, prof, flush_rows, **kw):
    s1, r1, o1, seen = _analyse(path, prof, True, flush_rows, **kw)
    s2, r2, o2, _ = _analyse(path, prof, False, **kw)
    assert len(s1) == len(s2)
    for a, b in zip(s1, s2):
        assert tuple(_bits(getattr(a, k)) for k in _KEYS) == tuple(_bits(getattr(b, k)) for k in _KEYS)
    assert [(f, _bits(v)) for f, v in o1.by_feature.items()] == [(f, _bits(v)) for f, v in o2.by_feature.items()]
    assert _bits([r1.time_t, r1.int_a2, r1.int_v2]) == _bits([r2.time_t, r2.int_a2, r2.int_v2])
    return s1, seen


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3"), ("prusa_gyroid_arcs.gcode", "voron24"),
                                       ("edge/tool_changes.gcode", "prusa-mk3s"),
                                       ("edge/no_feature_comments.gcode", "prusa-mk3s")])
@pytest.mark.parametrize("flush_rows,chunk", [(1, None), (37, None), (1, 700), (5, 3000)])
@pytest.mark.parametrize("kw", [{}, dict(features=feat.ALL, min_length_d=0.0)])
def test_flushed_log_is_the_per_record_path(name, prof, flush_rows, chunk, kw, monkeypatch):
    if chunk is not None:       # smaller chunks (characters): a flush looked at every ~20-90 lines
        monkeypatch.setattr(fwsim, "CHUNK_HINT", chunk)
    strokes, seen = _same(SAMPLES + name, prof, flush_rows, **kw)
    # a flush is looked at each chunk after the first: it came, it dropped records
    if sum(1 for _ in fwsim.read_chunks(SAMPLES + name)) > 1:
        assert seen and any(after < before for before, after in seen)


@pytest.mark.skipif(not os.path.exists(_CORPUS + "bridges.gcode"), reason="corpus not here")
def test_flushed_log_corpus():
    """A real file with many flushes at the default size and at a small one: the log holds a
    few chunks' records, not the file's."""
    path = _CORPUS + "bridges.gcode"
    for rows in (pl.LOG_FLUSH_ROWS, 1000):
        strokes, seen = _same(path, "prusa-mk3s", rows)
        assert strokes and seen
        assert max(after for _, after in seen) < rows


def _records(path, prof):
    """The compiled model's records of a file, as LineRecords and in a RecordLog."""
    from gcode_opt import state as st
    recs, log = [], fwsim._core.RecordLog()

    def both(r):
        recs.append(r)
        log(r)
    sim = fwsim.new_sim(load_profile(prof), both)
    state = st.MachineState(load_profile(prof), path)
    for idx, raw in st.read_lines(path):
        ev = state.step(idx, raw)
        if type(ev) is st.Move:
            sim.move(ev)
        elif type(ev) is st.Barrier:
            sim.barrier(ev)
    sim.stop()
    assert log.rows == len(recs) > 100
    return recs, log


def _tally(recs, starts, ids, nf):
    """feature_sums by hand: [count, t, a2, first position] per feature."""
    want = [[0, 0.0, 0.0, -1] for _ in range(nf)]
    for j, r in enumerate(recs):
        p = [k for k, s0 in enumerate(starts) if s0 <= r.idx]
        if not p:
            continue
        w = want[ids[p[-1]]]
        w[0] += 1
        w[1] += r.time_t
        w[2] += r.int_a2 + r.int_a2_j
        if w[3] < 0:
            w[3] = j
    return want


def test_log_pieces_against_python():
    """below, drop, last and feature_sums(..., stop) taken in random prefixes: the sums of
    one pass over all the records, the records left those after the cuts."""
    recs, log = _records(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
    n_lines = recs[-1].idx + 2
    assert log.last == recs[-1].idx
    assert fwsim._core.RecordLog().last == -1
    rng = random.Random(23)
    starts = np.array(sorted(rng.sample(range(n_lines), 25)), np.int64)
    nf = 4
    ids = np.array([rng.randrange(nf) for _ in starts], np.int64)
    want = _tally(recs, starts, ids, nf)
    count, first = np.zeros(nf, np.int64), np.full(nf, -1, np.int64)
    ft, fa2 = np.zeros(nf), np.zeros(nf)
    dropped = 0
    lines = sorted(rng.sample(range(n_lines), 12)) + [n_lines + 5]
    for line in lines:
        k = log.below(line)
        assert k == sum(1 for r in recs[dropped:] if r.idx < line)
        part = np.full(nf, -1, np.int64)
        log.feature_sums(starts, ids, count, ft, fa2, part, k)
        new = (first < 0) & (part >= 0)
        first[new] = part[new] + dropped
        log.drop(k)
        dropped += k
        assert log.rows == len(recs) - dropped
        # what is left is the records after the cut, in order: their stroke sums as before
        if log.rows:
            lo = np.array([recs[dropped].idx], np.int64)
            hi = np.array([recs[-1].idx], np.int64)
            got, v = np.zeros(1, np.int64), [np.zeros(1) for _ in range(5)]
            log.stroke_sums(lo, hi, got, *v)
            s_t = 0.0
            for r in recs[dropped:]:
                s_t += r.time_t
            assert _bits(float(v[2][0])) == _bits(s_t)
    assert log.rows == 0 and dropped == len(recs)
    got_t = [[int(count[f]), float(ft[f]), float(fa2[f]), int(first[f])] for f in range(nf)]
    assert _bits(got_t) == _bits(want)
    with pytest.raises(ValueError):
        log.drop(1)                                   # more than it holds
