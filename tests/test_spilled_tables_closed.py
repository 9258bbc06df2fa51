"""The candidate tables set aside for a re-plan (Candidates.spill: an unnamed temporary file)
are closed by the pipeline when no re-plan comes, not left to the collector (which closed
them with a ResourceWarning, one a run)."""
import numpy as np

from gcode_opt import schedule
from gcode_opt.pipeline import Options, process
from gcode_opt.plan import Candidates, SpilledCandidates
from gcode_opt.profile import load_profile


def test_process_closes_every_spilled_file(tmp_path, monkeypatch):
    made = []
    spill = Candidates.spill

    def recording_spill(self, folder=None):
        s = spill(self, folder)
        if s is not None:
            made.append((s, s.fh))
        return s
    monkeypatch.setattr(Candidates, "spill", recording_spill)
    process("sample_gcode/prusa_gyroid.gcode", str(tmp_path / "o.gcode"), load_profile("prusa-mk3s"), Options())
    assert made                                   # (the first pass sets its tables aside)
    assert all(s.fh is None and fh.closed for s, fh in made)


def _spilled():
    mask = np.array([[True, False, True], [False, True, True]])
    vals = np.arange(16.0).reshape(4, 4)
    c = Candidates(mask, vals, np.array([True, True]), np.ones((2, 1)))
    s = c.spill()
    assert isinstance(s, SpilledCandidates)
    return c, s


def test_drop_cached_closes_the_file_and_forgets_it():
    _, s = _spilled()
    fh = s.fh

    class Pin:
        cached = (s, None, [])
    pin = Pin()
    schedule.drop_cached(pin)
    assert fh.closed and s.fh is None and pin.cached is None
    schedule.drop_cached(pin)           # (nothing cached: nothing to do)
    assert pin.cached is None


def test_load_still_gives_the_tables_back_and_closes():
    c, s = _spilled()
    fh = s.fh
    back = s.load()
    assert fh.closed and s.fh is None
    for name in Candidates.SPILLED:
        a, b = getattr(c, name), getattr(back, name)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    s.close()                            # (a second close does nothing)
