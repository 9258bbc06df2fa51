"""GeomKeep's records written as pieces (sto65: GeomKeep._append_pieces' gathered writes, no
joined copy of the record): the file holds the bytes the joined write wrote -- with
os.pwritev, without it (the pieces joined, SpillFile.append), and after short gathered
writes (the rest written as it is) -- and the records' index is the same."""
import os
from pathlib import Path

import numpy as np

from gcode_opt import geom_keep, pipeline
from gcode_opt import features as feat
from gcode_opt.geom_keep import GeomKeep
from gcode_opt.plan_windows import plan_inputs_windowed
from gcode_opt.profile import load_profile
from gcode_opt.stroke_store import StrokeStore

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
NAME = "prusa_gyroid_fullspeed.gcode"
WINDOW, PIN = 37, 100


class _Both:
    """Hands each put to every keep, the writer of each set as it asks (the same strokes'
    blocks: the same doubles, uninitialised κ rows included)."""

    def __init__(self, keeps):
        self.keeps = keeps

    def put(self, lo, sts, codes):
        for keep, writev in self.keeps:
            geom_keep._PWRITEV = writev
            keep.put(lo, sts, codes)


def _short(fd, bufs, pos):
    """os.pwritev writing at most its first buffer and 3 bytes of the next (a short write)."""
    head = bytes(bufs[0]) + (bytes(bufs[1][:3]) if len(bufs) > 1 else b"")
    return os.pwrite(fd, head, pos)


def _bytes(keep):
    return os.pread(keep.fh.fileno(), keep.end * 8, 0)


def test_pieces_written_are_the_joined_record(tmp_path, monkeypatch):
    prof = load_profile("prusa-mk3s")
    path = str(SAMPLES / NAME)
    opts = pipeline.Options(features=feat.default_selection(path)[0])
    store = StrokeStore(folder=str(tmp_path))
    pipeline.analyse(path, prof, opts, store)
    monkeypatch.setattr(geom_keep, "_PWRITEV", geom_keep._PWRITEV)      # (restored after)
    monkeypatch.setattr(geom_keep, "_IOV_MAX", 3)        # (a record in several gathered writes)
    keeps = [(GeomKeep(WINDOW, prof, str(tmp_path)), w) for w in (os.pwritev, None, _short)]
    plan_inputs_windowed(store, prof, opts, PIN, _Both(keeps))
    (gathered, _), (joined, _), (short, _) = keeps
    assert gathered.end > 0 and len(gathered.recs) > 1
    assert _bytes(gathered) == _bytes(joined) == _bytes(short)
    assert gathered.recs == joined.recs == short.recs
    assert gathered.end == joined.end == short.end
    # the head of each record: its parts, rows and chain caps' doubles, as the joined record's
    at, n_main, n_kap = gathered.recs[min(gathered.recs)][0]
    head = np.frombuffer(_bytes(gathered)[8 * at:8 * at + 24], float)
    assert head[0] >= 1 and head[1] >= 1 and n_main > 3 + head[0] * 3
