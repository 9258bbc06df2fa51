"""analyse's _LogSums keeps only the feature changes it still looks up (issue 8, s33): it takes
feat_at's new entries out of it at each flush and drops the changes before the one in force
at the flush's cut, so a flush converts a few entries, not every change since the file's top
(the gyroid plate has tens of thousands).  The sums stay those of the per-record Python path
(test_speed23_group_logflush.py checks them bit for bit with flushes forced often); here: what
the sums hold after each flush, and the same figures with and without the trimming."""
import os
import struct

import pytest

from gcode_opt import pipeline as pl
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile

SAMPLES = "sample_gcode/"
_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")
pytestmark = pytest.mark.skipif(fwsim.CORE != "c" or not hasattr(fwsim._core, "RecordLog"),
                                reason="the compiled firmware model is not in use here")


def _bits(x):
    return struct.pack("<d", x) if isinstance(x, float) else x


def _analyse(path, flush_rows, monkeypatch, trim=True):
    """analyse with flushes every flush_rows records (trim False: every change kept, as
    before s33); per flush (feat_at's entries left, changes kept, the first kept's line),
    and the strokes' and features' figures as bits."""
    seen = []
    flush, features = pl._LogSums.flush, pl._LogSums._features

    def spy(self, open_line):
        flush(self, open_line)
        seen.append((len(self.feat_at), len(self.starts), self.starts[0] if len(self.starts) else None))

    def untrimmed(self, rows, line=None):
        features(self, rows)         # (no cut)
    monkeypatch.setattr(pl, "LOG_FLUSH_ROWS", flush_rows)
    monkeypatch.setattr(pl._LogSums, "flush", spy)
    if not trim:
        monkeypatch.setattr(pl._LogSums, "_features", untrimmed)
    o = pl.Options()
    strokes, res = pl.analyse(path, load_profile("prusa-mk3s"), o)
    figures = ([tuple(_bits(getattr(s, k)) for k in ("v0", "v1", "time_t", "int_a2", "int_v2")) for s in strokes],
               [(f, tuple(_bits(v) for v in t)) for f, t in o.by_feature.items()])
    return seen, figures


@pytest.mark.parametrize("path", [SAMPLES + "prusa_gyroid.gcode", SAMPLES + "prusa_klipper.gcode",
                                  _CORPUS + "bridges.gcode"])
def test_flush_keeps_only_the_changes_still_looked_up(path, monkeypatch):
    if not os.path.exists(path):
        pytest.skip("corpus not here")
    monkeypatch.setattr(fwsim, "CHUNK_HINT", 3000)      # (a flush looked at every ~100 lines)
    seen, figures = _analyse(path, 50, monkeypatch)
    assert len(seen) > 5
    assert all(left == 0 for left, _, _ in seen)      # every entry of feat_at taken out of it
    # the changes kept stay few: those from the one in force at the cut on, not the file's
    n_kept = max(kept for _, kept, _ in seen)
    assert n_kept < 40
    starts = [first for _, _, first in seen if first is not None]
    assert starts == sorted(starts) and starts[-1] > starts[0]      # the front moves down the file
    # and the figures are those of the flushes without the cut
    seen_u, figures_u = _analyse(path, 50, monkeypatch, trim=False)
    assert figures == figures_u
    assert max(kept for _, kept, _ in seen_u) > 2 * n_kept
