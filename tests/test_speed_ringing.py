"""The written file's ringing rides on the measure pass (issue 8): the figures must be the
ones a separate firmware-model pass over the file gives (ringing.figures), exactly."""
import json

import pytest

from gcode_opt import cli, ringing
from gcode_opt.pipeline import Options, measure, process
from gcode_opt.profile import load_profile
from gcode_opt.state import read_lines

SAMPLES = "sample_gcode/"


def _with_dwells(src, dst, every=40):
    """A copy of src with a 0.25 s dwell before every `every`-th G1 line: barriers whose dwell
    the ringing must see as rest (no bundled sample dwells)."""
    n = 0
    with open(dst, "w", newline="") as fo:
        for _, raw in read_lines(src):
            if raw.startswith("G1 "):
                n += 1
                if n % every == 0:
                    fo.write("G4 P250\n")
            fo.write(raw)


@pytest.mark.parametrize("watch", [False, True])
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "voron24"), ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s")])
def test_ringing_riding_on_measure_equals_its_own_pass(tmp_path, name, prof, watch):
    profile = load_profile(prof)
    path = str(tmp_path / "dwell.gcode")
    _with_dwells(SAMPLES + name, path)
    n_lines = sum(1 for _ in read_lines(path))
    # watched ranges (a ledger pass) that hold no stop: short ranges far apart
    rng = [(i, i) for i in range(5, n_lines, 997)] if watch else None
    col = ringing.Collector(profile)
    sim, _, _, _, led = measure(path, profile, [], Options(), rng, ring=col)
    assert (led is not None) == watch
    alone = measure(path, profile, [], Options(), rng)[0]
    assert sim.as_dict() == alone.as_dict()            # the ride changes nothing of the model's figures
    got, want = col.figures(), ringing.figures(path, profile)
    assert got == want
    assert sim.barrier_dwell_t > 1.0 and want["xy"]["rms_um"] > 0     # the dwells were played


def test_process_ringing_equals_separate_figures(tmp_path, monkeypatch):
    """One pass: the figures rode on the measure pass; two: the second pass played only
    the stretches that changed, so the written file was played once more.  Both happen
    on these runs (if planning changes that, pick another run for the missing case)."""
    # segments.JERK_CORNERS (session 29) keeps classic-jerk corners, and this sample (prusa-mk3s)
    # no longer overruns its budget: one pass.  Off, the segments are those this test was made on
    # (two passes under prusa-mk3s; other profiles are not touched by it)
    from gcode_opt import segments as _segments
    monkeypatch.setattr(_segments, "JERK_CORNERS", False)
    passes = set()
    for prof in ("voron24", "prusa-mk3s"):
        profile = load_profile(prof)
        src = SAMPLES + "prusa_gyroid.gcode"
        out = str(tmp_path / f"{prof}.gcode")
        s = process(src, out, profile, Options())
        passes.add(s["rewrite_passes"])
        assert s["strokes"]["retimed"] > 0
        r = s["ringing"]
        assert r["before"] == ringing.figures(src, profile)
        assert r["after"] == ringing.figures(out, profile)
        assert r == json.loads(json.dumps(ringing.summary_of(r["before"], r["after"])))
    assert passes == {1, 2}


def test_add_ringing_plays_an_unchanged_file_once(tmp_path, monkeypatch):
    """The CLI's fallback on a written file that is the original byte for byte: one pass,
    no change; on a changed file, one pass per file."""
    profile = load_profile("prusa-mk3s")
    src = SAMPLES + "prusa_gyroid.gcode"
    same = tmp_path / "same.gcode"
    same.write_bytes(open(src, "rb").read())
    calls = []
    real = ringing.figures
    monkeypatch.setattr(ringing, "figures", lambda p, prof, shaper=None: calls.append(p) or real(p, prof, shaper))
    summary = {}
    cli.add_ringing(summary, src, str(same), profile)
    assert calls == [src]
    assert summary["ringing"]["change"]["rms_um"]["change"] == 0.0
    assert summary["ringing"]["after"] == real(str(same), profile)
    other = tmp_path / "other.gcode"
    other.write_bytes(open(src, "rb").read().replace(b"G1 ", b"G1  ", 1))   # same moves, other bytes
    calls.clear()
    cli.add_ringing(summary, src, str(other), profile)
    assert calls == [src, str(other)]
