"""The ringing's ramp / corner / turn parts are figured only where something reads them.

Collector(parts=False) solves the whole ringing alone (2 of its 8 streams); the command line
asks for the parts only with --json, --report or --corners auto.  Checked here against the
Collector with its parts (the reference: every figure the product printed before), on
bundled real slicer files, with and without an input shaper."""
import json
import os

import pytest

from gcode_opt import cli, ringing
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")
PART_KEYS = ("rms_ramp_um", "rms_corner_um", "rms_turn_um", "peak_ramp_um", "peak_corner_um", "peak_turn_um")


def _figures(path, profile, parts, shaper=None):
    col = ringing.Collector(profile, shaper, parts=parts)
    ringing.play(path, profile, col)
    return col.figures()


@pytest.mark.parametrize("name,prof,shaper", [("prusa_gyroid.gcode", "prusa-mk3s", None),
                                              ("prusa_klipper.gcode", "voron24", None),
                                              ("prusa_concentric_arcs.gcode", "voron24", "mzv")])
def test_whole_ringing_is_the_same_bits_without_the_parts(name, prof, shaper):
    profile = load_profile(prof)
    path = os.path.join(SAMPLES, name)
    full = _figures(path, profile, True, shaper)
    only = _figures(path, profile, False, shaper)
    assert full["time_s"] == only["time_s"]
    for ax in ("x", "y"):
        for key in ("rms_um", "peak_um"):
            assert only[ax][key] == full[ax][key], (ax, key)      # bit for bit
        assert not any(k in only[ax] for k in PART_KEYS)
        assert all(k in full[ax] for k in PART_KEYS)
    assert only["xy"]["rms_um"] == full["xy"]["rms_um"] and only["xy"]["peak_um"] == full["xy"]["peak_um"]
    assert full["xy"]["rms_ramp_um"] > 0.0 and "rms_ramp_um" not in only["xy"]
    assert only.get("smoothing") == full.get("smoothing")
    # the summary's comparison keeps the keys both sides have
    ch = ringing.compare(only, full)
    assert ch["rms_um"]["before"] == full["xy"]["rms_um"] and "rms_ramp_um" not in ch
    assert ch["x"]["rms_um"]["after"] == full["x"]["rms_um"] and "rms_ramp_um" not in ch["x"]
    assert ringing.headline_text(ringing.summary_of(only, only)) == ringing.headline_text(ringing.summary_of(full, full))


def _run(tmp_path, tag, *extra, monkeypatch=None, seen=None):
    out = tmp_path / f"{tag}.gcode"
    code = cli.main(["process", os.path.join(SAMPLES, "prusa_gyroid.gcode"), "-o", str(out),
                     "--profile", "prusa-mk3s", *extra])
    assert code == 0
    return out.read_bytes()


@pytest.fixture
def parts_seen(monkeypatch):
    """The parts flag of every Collector the pipeline makes."""
    seen = []
    real = ringing.Collector.__init__

    def init(self, *a, **k):
        seen.append(k.get("parts", True))
        real(self, *a, **k)
    monkeypatch.setattr(ringing.Collector, "__init__", init)
    return seen


def test_command_line_asks_for_the_parts_only_where_shown(tmp_path, capsys, parts_seen):
    plain = _run(tmp_path, "plain")
    text_plain = capsys.readouterr().err
    assert parts_seen and not any(parts_seen)             # analyse's and measure's: no parts
    parts_seen.clear()
    js = tmp_path / "s.json"
    with_json = _run(tmp_path, "json", "--json", str(js))
    text_json = capsys.readouterr().err
    assert parts_seen and all(parts_seen)
    assert plain == with_json                             # the G-code does not depend on it
    ring_line = [ln for ln in text_plain.splitlines() if ln.strip().startswith("ringing")]
    assert ring_line and ring_line == [ln for ln in text_json.splitlines() if ln.strip().startswith("ringing")]
    r = json.loads(js.read_text())["ringing"]
    assert r["before"]["xy"]["rms_ramp_um"] > 0.0 and "rms_corner_um" in r["change"]


def test_corners_auto_gets_the_parts_it_prices_with(tmp_path, parts_seen):
    # corners.corner_share reads the original's ramp / corner / turn parts; without them it
    # would fall back to AUTO_FALLBACK_R silently
    a = _run(tmp_path, "auto", "--corners", "auto")
    assert parts_seen and all(parts_seen)
    parts_seen.clear()
    b = _run(tmp_path, "auto_json", "--corners", "auto", "--json", str(tmp_path / "a.json"))
    assert a == b
