"""analyse's records through the compiled model's RecordLog (summed per stroke and per
feature after the pass, pipeline._apply_log) against analyse's per-record on_line/apply:
the same strokes, bit for bit, and the same feature tally in the same order.  And the
log's two sums against a plain Python reading of the records, on random stroke ranges."""
import random
import struct

import numpy as np
import pytest

from gcode_opt import pipeline as pl
from gcode_opt import state as st
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile

SAMPLES = "sample_gcode/"
pytestmark = pytest.mark.skipif(fwsim.CORE != "c" or not hasattr(fwsim._core, "RecordLog"),
                                reason="the compiled firmware model is not in use here")

_KEYS = ("first_idx", "last_idx", "v0", "v1", "time_t", "int_a2", "int_v2")


def _bits(x):
    if isinstance(x, float):
        return struct.pack("<d", x)
    if isinstance(x, (list, tuple)):
        return tuple(_bits(y) for y in x)
    return x


def _analyse(path, prof, use_log, **kw):
    saved = pl._record_log
    if not use_log:
        pl._record_log = lambda: None
    try:
        o = pl.Options(**kw)
        strokes, res = pl.analyse(path, load_profile(prof), o)
    finally:
        pl._record_log = saved
    return strokes, res, o


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3"), ("prusa_gyroid_arcs.gcode", "voron24"),
                                       ("edge/tool_changes.gcode", "prusa-mk3s"),
                                       ("edge/no_feature_comments.gcode", "prusa-mk3s"),
                                       ("edge/firmware_retraction.gcode", "prusa-mk3s")])
@pytest.mark.parametrize("kw", [{}, dict(features="all", min_length_d=0.0)])
def test_log_is_the_per_record_path(name, prof, kw):
    if kw.get("features") == "all":
        from gcode_opt import features as feat
        kw = dict(kw, features=feat.ALL)
    s1, r1, o1 = _analyse(SAMPLES + name, prof, True, **kw)
    s2, r2, o2 = _analyse(SAMPLES + name, prof, False, **kw)
    assert len(s1) == len(s2)
    for a, b in zip(s1, s2):
        assert tuple(_bits(getattr(a, k)) for k in _KEYS) == tuple(_bits(getattr(b, k)) for k in _KEYS)
    # the tally: same features, same order (the order their first records came), same bits
    assert [(f, _bits(v)) for f, v in o1.by_feature.items()] == [(f, _bits(v)) for f, v in o2.by_feature.items()]
    assert _bits(o1.ringing_before) == _bits(o2.ringing_before)
    assert _bits([r1.time_t, r1.int_a2, r1.int_v2]) == _bits([r2.time_t, r2.int_a2, r2.int_v2])


def _records(path, prof):
    """The compiled model's records of a file, as LineRecords and in a RecordLog."""
    profile = load_profile(prof)
    recs, log = [], fwsim._core.RecordLog()

    def both(r):
        recs.append(r)
        log(r)                     # RecordLog's call: the record as the Sim would add it
    sim = fwsim.new_sim(profile, both)
    state = st.MachineState(profile, path)
    for idx, raw in st.read_lines(path):
        ev = state.step(idx, raw)
        if type(ev) is st.Move:
            sim.move(ev)
        elif type(ev) is st.Barrier:
            sim.barrier(ev)
    sim.stop()
    assert log.rows == len(recs) > 100
    return recs, log


def test_stroke_and_feature_sums_on_random_ranges():
    recs, log = _records(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
    n_lines = recs[-1].idx + 2
    rng = random.Random(7)
    for _ in range(20):
        # disjoint ranges in file order, some on lines without a record, some empty of records
        cuts = sorted(rng.sample(range(n_lines), 2 * rng.randint(1, 60)))
        lo = np.array(cuts[0::2], np.int64)
        hi = np.array(cuts[1::2], np.int64) - rng.choice([0, 1]) * (np.array(cuts[1::2]) > np.array(cuts[0::2]))
        n = len(lo)
        got = np.zeros(n, np.int64)
        v0, v1, t, a2, v2 = (np.zeros(n) for _ in range(5))
        log.stroke_sums(lo, hi, got, v0, v1, t, a2, v2)
        for q in range(n):
            g, w0, w1, s_t, s_a2, s_v2 = 0, 0.0, 0.0, 0.0, 0.0, 0.0
            for r in recs:
                if lo[q] <= r.idx <= hi[q]:
                    if r.idx == lo[q]:
                        g, w0 = g | 1, r.start_v
                    if r.idx == hi[q]:
                        g, w1 = g | 2, r.end_v
                    s_t += r.time_t
                    s_a2 += r.int_a2 + r.int_a2_j
                    s_v2 += r.int_v2
            assert got[q] == g
            assert _bits([float(v0[q]), float(v1[q]), float(t[q]), float(a2[q]), float(v2[q])]) == \
                _bits([w0, w1, s_t, s_a2, s_v2])
        # the tally: random change lines and feature numbers
        starts = np.array(sorted(rng.sample(range(n_lines), rng.randint(1, 30))), np.int64)
        nf = rng.randint(1, 5)
        ids = np.array([rng.randrange(nf) for _ in starts], np.int64)
        count, first = np.zeros(nf, np.int64), np.full(nf, -1, np.int64)
        ft, fa2 = np.zeros(nf), np.zeros(nf)
        log.feature_sums(starts, ids, count, ft, fa2, first)
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
        got_t = [[int(count[f]), float(ft[f]), float(fa2[f]), int(first[f])] for f in range(nf)]
        assert _bits(got_t) == _bits(want)


def test_log_refuses_wrong_buffers():
    log = fwsim._core.RecordLog()
    z = np.zeros(2)
    with pytest.raises(ValueError):
        log.stroke_sums(np.zeros(2), np.zeros(2, np.int64), np.zeros(2, np.int64), z, z, z, z, z)   # lo as floats
    with pytest.raises(ValueError):
        log.stroke_sums(np.zeros(2, np.int64), np.zeros(3, np.int64), np.zeros(2, np.int64), z, z, z, z, z)
    with pytest.raises(ValueError):
        log.feature_sums(np.zeros(1, np.int64), np.array([5], np.int64), np.zeros(2, np.int64), z, z,
                         np.full(2, -1, np.int64))       # a feature number out of range
    with pytest.raises(TypeError):
        log(1.0)                                          # not a LineRecord
