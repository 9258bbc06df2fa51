"""Ringing in the product (issue 10, "Done means"): the summary JSON, `gcode-opt simulate`
and the HTML report carry ringing per axis before/after, and their figures agree with an
independent whole-trace computation (ringing.figures_of_trace over ringing.trace) of the
same files."""
import json
import os
import shutil

import pytest

from gcode_opt import ringing as rg
from gcode_opt.cli import main
from gcode_opt.profile import load_profile
from gcode_opt.summary import ringing_section

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLE = os.path.join(ROOT, "sample_gcode", "prusa_mk3s_rectilinear.gcode")
PROFILE = "prusa-mk3s"
AXIS_KEYS = ("rms_um", "peak_um", "rms_ramp_um", "peak_ramp_um", "rms_corner_um", "peak_corner_um",
             "rms_turn_um", "peak_turn_um")


def _whole(path, prof):
    return rg.figures_of_trace(rg.trace(path, prof), rg.model_of(prof))


def _close(a, b, rel=1e-9):
    assert a.keys() == b.keys()
    for k in AXIS_KEYS:
        assert a[k] == pytest.approx(b[k], rel=rel, abs=1e-12), k


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    d = tmp_path_factory.mktemp("ring")
    out, summ, html = str(d / "o.gcode"), str(d / "s.json"), str(d / "r.html")
    assert main(["process", SAMPLE, "-o", out, "--profile", PROFILE, "--json", summ, "--report", html, "-q"]) == 0
    with open(summ) as fh:
        summary = json.load(fh)
    prof = load_profile(PROFILE)
    return {"dir": d, "out": out, "summary": summary, "html": html,
            "before": _whole(SAMPLE, prof), "after": _whole(out, prof)}


def test_summary_has_ringing_per_axis_before_after(processed):
    r = processed["summary"]["ringing"]
    assert r["model"] == rg.model_of(load_profile(PROFILE))
    for tag in ("before", "after"):
        for ax in ("x", "y"):
            _close(r[tag][ax], processed[tag][ax])
        assert r[tag]["xy"]["rms_um"] == pytest.approx(processed[tag]["xy"]["rms_um"], rel=1e-9)
    # change = after / before - 1, XY and per axis
    for sub in (r["change"], r["change"]["x"], r["change"]["y"]):
        for key in ("rms_um", "peak_um"):
            c = sub[key]
            assert c["change"] == pytest.approx(c["after"] / c["before"] - 1.0, rel=1e-12)
    assert r["change"]["x"]["rms_um"]["before"] == r["before"]["x"]["rms_um"]
    # re-timing lowers the ramp part on this sample (issue 10: box at 50 Hz 3.5 -> 2.7 um)
    assert r["after"]["xy"]["rms_ramp_um"] < 0.9 * r["before"]["xy"]["rms_ramp_um"]
    assert "smoothing" not in r["before"]                   # the profile sets no shaper


def test_summary_line_and_no_ringing(processed, tmp_path, capsys):
    from gcode_opt.cli import format_summary
    line = [x for x in format_summary(processed["summary"]).splitlines() if x.strip().startswith("ringing")]
    r = processed["before"]["xy"]
    assert len(line) == 1 and f"RMS {r['rms_um']:.2f} -> " in line[0] and "no input shaper" in line[0]
    out, summ = str(tmp_path / "o.gcode"), str(tmp_path / "s.json")
    assert main(["process", SAMPLE, "-o", out, "--profile", PROFILE, "--no-ringing", "--json", summ]) == 0
    err = capsys.readouterr().err
    assert "whole file" in err                                   # the summary was printed ...
    assert not any(x.strip().startswith("ringing") for x in err.splitlines())    # ... without ringing
    with open(summ) as fh:
        s = json.load(fh)
    assert "ringing" not in s and "ringing_error" not in s and "coverage" in s


def test_ringing_section_from_two_figure_dicts():
    prof = rg.with_shaper(load_profile("voron24"), "mzv")
    a = os.path.join(ROOT, "sample_gcode", "prusa_klipper.gcode")
    b = os.path.join(ROOT, "sample_gcode", "prusa_klipper_no_comments.gcode")
    fa, fb = rg.figures(a, prof), rg.figures(b, prof)
    r = ringing_section(fa, fb)
    assert r["before"] is fa and r["after"] is fb
    wa = _whole(a, prof)
    assert r["change"]["smoothing_rms_um"]["before"] == pytest.approx(wa["smoothing"]["rms_um"], rel=1e-9)
    assert "shaper smoothing" in rg.headline_text(r)
    assert "MZV" in rg.headline_text(r)
    with pytest.raises(ValueError):
        ringing_section(fa, rg.figures(b, load_profile("voron24")))     # different shapers


def test_simulate_prints_and_returns_ringing(capsys, tmp_path):
    prof = load_profile(PROFILE)
    assert main(["simulate", SAMPLE, "--profile", PROFILE, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    ref = _whole(SAMPLE, prof)
    for ax in ("x", "y"):
        _close(d["ringing"][ax], ref[ax])
    assert d["time_t"] == pytest.approx(ref["time_s"], rel=1e-12)      # one pass: the same print time
    assert main(["simulate", SAMPLE, "--profile", PROFILE]) == 0
    text = capsys.readouterr().out
    assert "ringing RMS / peak" in text and f"{ref['xy']['rms_um']:.2f}" in text
    assert main(["simulate", SAMPLE, "--profile", PROFILE, "--json", "--no-ringing"]) == 0
    assert "ringing" not in json.loads(capsys.readouterr().out)


def test_simulate_with_a_shaper_profile(capsys, tmp_path):
    """A profile file that sets MZV: simulate reports the shaped ringing and the smoothing."""
    src = os.path.join(ROOT, "profiles", "voron24.toml")
    text = open(src).read().replace('shaper = "none"', 'shaper = "mzv"')
    assert 'shaper = "mzv"' in text
    pf = tmp_path / "voron24-mzv.toml"
    pf.write_text(text)
    sample = os.path.join(ROOT, "sample_gcode", "prusa_klipper.gcode")
    assert main(["simulate", sample, "--profile", str(pf), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    ref = rg.figures_of_trace(rg.trace(sample, load_profile("voron24")), rg.model_of(load_profile("voron24")), "mzv")
    assert d["ringing"]["model"]["shaper"] == "mzv"
    assert d["ringing"]["smoothing"]["rms_um"] == pytest.approx(ref["smoothing"]["rms_um"], rel=1e-9)
    _close(d["ringing"]["x"], ref["x"])


def test_report_shows_ringing(processed):
    from html.parser import HTMLParser
    from gcode_opt.report.data import build_report
    s = processed["summary"]
    data, _ = build_report(SAMPLE, processed["out"], load_profile(PROFILE), s)
    h = data["ringing"]["headline"]
    assert h["rms_um"]["before"] == s["ringing"]["change"]["rms_um"]["before"]
    assert data["headline"]["ringing_rms_um"]["after"] == s["ringing"]["after"]["xy"]["rms_um"]
    assert h["y"]["peak_um"]["after"] == pytest.approx(processed["after"]["y"]["peak_um"], rel=1e-9)
    # without the summary the report figures it from its own passes: the same numbers
    own, _ = build_report(SAMPLE, processed["out"], load_profile(PROFILE), None)
    assert own["ringing"]["headline"]["x"]["rms_um"]["after"] == pytest.approx(
        h["x"]["rms_um"]["after"], rel=1e-9)

    class Page(HTMLParser):
        keys, imgs = set(), []

        def handle_starttag(self, tag, attrs):
            a = dict(attrs)
            if "data-key" in a:
                self.keys.add(a["data-key"])
            if tag == "img":
                self.imgs.append(a.get("alt", ""))
    p = Page()
    with open(processed["html"], encoding="utf-8") as fh:
        p.feed(fh.read())
    for k in ("headline.ringing_rms_um.before", "headline.ringing_peak_um.after",
              "ringing.headline.x.rms_um.before", "ringing.headline.y.peak_um.after",
              "ringing.headline.rms_corner_um.change", "headline.ringing_rms_um.change"):
        assert k in p.keys, k
    assert any("ringing" in alt for alt in p.imgs)


def test_report_no_ringing(processed, tmp_path):
    html, js = str(tmp_path / "r.html"), str(tmp_path / "r.json")
    assert main(["report", SAMPLE, processed["out"], "--profile", PROFILE, "-o", html, "--json", js,
                 "--no-ringing"]) == 0
    with open(js) as fh:
        d = json.load(fh)
    assert "ringing" not in d and "ringing_rms_um" not in d["headline"]
    assert "Ringing" not in open(html, encoding="utf-8").read()


def test_bgcode_process_has_ringing(tmp_path):
    """A binary G-code input: the ringing is figured on its decoded text, like the rest."""
    import gzip
    bg = os.path.join(ROOT, "tests", "bgcode", "cut_default.bgcode")
    src, ref = str(tmp_path / "in.bgcode"), str(tmp_path / "ref.gcode")
    shutil.copy(bg, src)
    with gzip.open(bg[:-len(".bgcode")] + ".ref.gcode.gz") as fh, open(ref, "wb") as out:
        out.write(fh.read())                            # libbgcode's own decoding of the same file
    summ = str(tmp_path / "s.json")
    assert main(["process", src, "-o", str(tmp_path / "o.bgcode"), "--profile", PROFILE, "--json", summ, "-q"]) == 0
    with open(summ) as fh:
        r = json.load(fh)["ringing"]
    _close(r["before"]["x"], _whole(ref, load_profile(PROFILE))["x"])
