"""The analyse pass, round 47 (issue 8), same bits:

- the model's Sim.run_lines makes the first Move of each run it opens slot by slot in C
  (no call of strokes._head_move a run): every slot must be what _head_move gives for
  the same arguments (the same objects where it passes objects on, the same types);
- its strokes (stroke_new, its fields written by a plan of their kinds) must still be
  the reference's, slot for slot (test_speed_analyse2_runs' verbatim copy of the code
  that read line by line);
- pipeline._LogSums.flush finds the strokes to sum with line_spans and searchsorted and
  _features takes feat_at's notes at once: the same sums, tally and order as the code it
  replaced (a verbatim copy below, commit 882d7e9), flushed often."""
from __future__ import annotations

import os
import random
from bisect import bisect_right

import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import strokes
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile
from gcode_opt.state import Move
from gcode_opt.strokes import line_spans, put_sums
from test_speed_analyse2_runs import COMPILED, _random_file, _same
from test_speed_analyse import _bits

SAMPLES = "sample_gcode/"
_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")

pytestmark = pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")


# ---------------------------------------------------------------- the runs' first Moves made in C
class _Heads:
    """Wraps group_lines' fast (Sim.run_lines): after each call that opened runs, run[0]
    (the Move made in C) against strokes._head_move of the same doubles and the first Move
    handed in (whose objects it copies)."""

    def __init__(self, monkeypatch):
        self.checked = 0
        real = pl.group_lines

        def group_lines(*a):
            a = list(a)
            f = a[-2]
            if f is not None:
                def fast(*x, _f=f):
                    run = x[0]
                    proto = run[0]
                    got = _f(*x)
                    if got and got[7]:
                        self.check(proto, run[0])
                    return got
                a[-2] = fast
            return real(*a)
        monkeypatch.setattr(pl, "group_lines", group_lines)

    def check(self, proto, mv):
        assert type(proto) is Move and type(mv) is Move and mv is not proto
        want = strokes._head_move(proto, mv.idx, mv.x0, mv.y0, mv.z0, mv.x1, mv.y1, mv.z1, mv.e, mv.v, mv.has_f)
        for name in Move.__slots__:
            a, b = getattr(mv, name), getattr(want, name)
            assert type(a) is type(b) and _bits(a) == _bits(b), name
            if not isinstance(b, (int, float)) or isinstance(b, bool):
                assert a is b, name                  # the objects _head_move passes on, the constants
        assert mv.has_f in (True, False) and type(mv.idx) is int and type(mv.x0) is float
        self.checked += 1


@pytest.mark.parametrize("name,prof,kw", [("prusa_gyroid.gcode", "prusa-mk3s", {}),
                                          ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", {}),
                                          ("prusa_klipper.gcode", "voron24", dict(features=feat.ALL)),
                                          ("cura_box.gcode", "ender3", dict(max_turn_deg=0.0))])
def test_run_heads_made_in_c_are_head_move(monkeypatch, name, prof, kw):
    heads = _Heads(monkeypatch)
    _same(SAMPLES + name, prof, ringing=False, **kw)      # and every stroke slot is the reference's
    assert heads.checked > 5


def test_run_heads_plate(monkeypatch):
    path = _CORPUS + "plate_rectilinear.gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    heads = _Heads(monkeypatch)
    _same(path, "prusa-mk3s", ringing=False)
    assert heads.checked > 1000


@pytest.mark.parametrize("seed", range(4))
def test_random_files_strokes_are_the_reference(tmp_path, seed):
    rng = random.Random(4700 + seed)
    path = tmp_path / "r.gcode"
    path.write_text(_random_file(rng, 1500))
    _same(str(path), "prusa-mk3s")


# ---------------------------------------------------------------- _LogSums: the code it replaced
class _OldLogSums(pl._LogSums):
    """pipeline._LogSums' flush, _strokes and _features as they were (882d7e9, verbatim)."""

    def flush(self, open_line):
        log = self.log
        line = min(open_line, log.last)
        strokes, k = self.strokes, self.done
        n = len(strokes)
        while k < n and strokes[k].last_idx < line:
            k += 1
        self._strokes(k)
        if k < n:
            line = min(line, strokes[k].first_idx)
        self._features(log.below(line), line)

    def _strokes(self, stop):
        """strokes[done:stop]'s sums from the log (all their records are in it)."""
        batch = self.strokes[self.done:stop]
        n = len(batch)
        if not n:
            return
        lo, hi = line_spans(batch)
        if not (np.all(hi >= lo) and np.all(lo[1:] > hi[:-1]) and lo[0] > self.last_hi):
            raise AssertionError("strokes out of file order")     # group_lines closes them in order
        self.done, self.last_hi = stop, int(hi[-1])
        got = np.zeros(n, np.int64)
        v0, v1, t, a2, v2 = (np.zeros(n) for _ in range(5))
        self.log.stroke_sums(lo, hi, got, v0, v1, t, a2, v2)
        put_sums(batch, got, v0, v1, t, a2, v2)

    def _features(self, rows, line=None):
        if not rows:
            return
        feat_at, ids, fid, starts = self.feat_at, self.ids, self.fid, self.starts
        while feat_at:            # its new entries (analyse's read and gap_lines append to it)
            i, f = feat_at.popleft()
            starts.append(i)
            fid.append(ids.setdefault(f, len(ids)))
        nf = len(ids)
        if nf > len(self.count):           # more features: the sums so far kept as they are
            grow = max(nf, 2 * len(self.count)) - len(self.count)
            self.count = np.concatenate((self.count, np.zeros(grow, np.int64)))
            self.first = np.concatenate((self.first, np.full(grow, -1, np.int64)))
            self.ft = np.concatenate((self.ft, np.zeros(grow)))
            self.fa2 = np.concatenate((self.fa2, np.zeros(grow)))
        first = np.full(len(self.count), -1, np.int64)     # positions in this prefix
        self.log.feature_sums(starts, fid, self.count, self.ft, self.fa2, first, rows)
        new = (self.first < 0) & (first >= 0)
        self.first[new] = first[new] + self.dropped
        self.log.drop(rows)
        self.dropped += rows
        if line is not None:
            k = bisect_right(starts, line) - 1      # the change in force at line (-1: none yet)
            if k > 0:
                del starts[:k], fid[:k]


_KEYS = ("first_idx", "last_idx", "v0", "v1", "time_t", "int_a2", "int_v2")


def _analyse(monkeypatch, path, prof, cls, flush_rows, chunk=None, **kw):
    """analyse with cls as its _LogSums, flushed every flush_rows records (looked at each chunk:
    chunk, if given, the reader's chunk size in characters); its strokes' sums,
    the feature tally (in order), the flushes made, the ids and the features' state at the end."""
    made = []

    def sums(*a):
        s = cls(*a)
        made.append(s)
        return s
    with monkeypatch.context() as m:
        m.setattr(pl, "_LogSums", sums)
        m.setattr(pl, "LOG_FLUSH_ROWS", flush_rows)
        if chunk is not None:
            m.setattr(fwsim, "CHUNK_HINT", chunk)
        calls = []
        real = cls.flush

        def flush(self, open_line):
            calls.append((self.done, self.log.rows))
            real(self, open_line)
            calls.append((self.done, self.log.rows))
        m.setattr(cls, "flush", flush)
        o = pl.Options(**kw)
        o.ringing = False
        st, _ = pl.analyse(path, load_profile(prof), o)
    s = made[0]
    return ([tuple(_bits(getattr(x, k)) for k in _KEYS) for x in st], _bits(list(o.by_feature.items())), calls,
            (dict(s.ids), list(s.starts), list(s.fid), s.dropped, s.last_hi))


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3"), ("edge/tool_changes.gcode", "prusa-mk3s"),
                                       ("edge/no_feature_comments.gcode", "prusa-mk3s")])
@pytest.mark.parametrize("flush_rows,chunk", [(1, 700), (7, 700), (300, 3000), (pl.LOG_FLUSH_ROWS, None)])
@pytest.mark.parametrize("kw", [{}, dict(features=feat.ALL, min_length_d=0.0)])
def test_log_sums_are_the_code_replaced(monkeypatch, name, prof, flush_rows, chunk, kw):
    """Every flush sums the same strokes, drops the same records, keeps the same feature
    notes; the sums and the tally are the same bits."""
    new = _analyse(monkeypatch, SAMPLES + name, prof, pl._LogSums, flush_rows, chunk, **kw)
    old = _analyse(monkeypatch, SAMPLES + name, prof, _OldLogSums, flush_rows, chunk, **kw)
    assert new == old
    if flush_rows < 10 and not name.startswith("edge/"):     # many flushes, many summing strokes
        calls = new[2]
        assert len(calls) // 2 > 10 and sum(a[0] != b[0] for a, b in zip(calls[::2], calls[1::2])) > 10


def test_log_sums_plate(monkeypatch):
    path = _CORPUS + "plate_rectilinear.gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    new = _analyse(monkeypatch, path, "prusa-mk3s", pl._LogSums, 5000)
    old = _analyse(monkeypatch, path, "prusa-mk3s", _OldLogSums, 5000)
    assert new == old and len(new[2]) > 20


def test_log_sums_strokes_out_of_order_raise():
    """flush checks the strokes it reads are in file order, as _strokes did."""
    log = fwsim._core.RecordLog()
    sums = pl._LogSums(log, [], __import__("collections").deque(), {})
    for lo, hi, last in (([5, 3], [6, 4], -1), ([5, 7], [6, 6], -1), ([5, 7], [4, 8], -1), ([5], [6], 5)):
        with pytest.raises(AssertionError):
            sums._file_order(np.array(lo, np.int64), np.array(hi, np.int64), last)
    sums._file_order(np.array([5, 7], np.int64), np.array([6, 9], np.int64), 4)
    sums._file_order(np.array([], np.int64), np.array([], np.int64), 4)
