"""The HTML/JSON report: runs the real pipeline on a sample, opens the HTML, checks every
number it shows against the JSON, the JSON against the pipeline's summary, and that every
embedded picture decodes and is not blank."""
import base64
import io
import json
import math
import os
from html.parser import HTMLParser

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from gcode_opt.cli import main  # noqa: E402
from gcode_opt.profile import load_profile  # noqa: E402
from gcode_opt.report.data import build_report  # noqa: E402
from gcode_opt.report.fences import parse_fences  # noqa: E402
from gcode_opt.report.fmt import fmt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLE = os.path.join(ROOT, "sample_gcode", "prusa_mk3s_rectilinear.gcode")
ARCS = os.path.join(ROOT, "sample_gcode", "edge", "arcs.gcode")
PROFILE = "prusa-mk3s"


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.keyed = []          # (key, unit, value json, text)
        self.imgs = []
        self.tags = []
        self._open = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append((tag, a))
        if tag == "img":
            self.imgs.append(a)
        if "data-key" in a:
            self._open.append([a["data-key"], a["data-unit"], a["data-value"], ""])

    def handle_data(self, data):
        for o in self._open:
            o[3] += data

    def handle_endtag(self, tag):
        if self._open and tag in ("td", "b", "span"):
            self.keyed.append(tuple(self._open.pop()))


def _parse(path):
    p = _Page()
    with open(path, encoding="utf-8") as fh:
        p.feed(fh.read())
    p.close()
    return p


def _get(d, key):
    for k in key.split("."):
        d = d[int(k)] if isinstance(d, list) else d[k]
    return d


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("report")
    out, summ, html = str(d / "o.gcode"), str(d / "s.json"), str(d / "r.html")
    assert main(["process", SAMPLE, "-o", out, "--profile", PROFILE, "--json", summ, "--report", html, "-q"]) == 0
    with open(summ) as fh:
        summary = json.load(fh)
    rjson, rhtml = str(d / "r2.json"), str(d / "r2.html")
    assert main(["report", SAMPLE, out, "--profile", PROFILE, "-o", rhtml, "--json", rjson]) == 0
    with open(rjson) as fh:
        plain = json.load(fh)
    data, _ = build_report(SAMPLE, out, load_profile(PROFILE), summary)
    return {"dir": d, "out": out, "summary": summary, "html": html, "data": data, "plain": plain,
            "plain_html": rhtml}


def test_html_numbers_match_json(run):
    page = _parse(run["html"])
    assert len(page.keyed) > 50
    keys = {k for k, *_ in page.keyed}
    for k in ("headline.print_time_s.before", "headline.print_time_s.after",
              "headline.int_a2_retimed_mm2_s3.before", "headline.int_a2_whole_mm2_s3.after",
              "headline.kinetic_whole_J_s.before", "headline.J_retimed_J_s.after",
              "headline.peak_speed_mm_s.after", "headline.peak_accel_mm_s2.after",
              "headline.strokes.retimed", "headline.file.bytes.after", "headline.file.lines.after",
              "headline.corners.before", "headline.corner_dv2_mm2_s2.after", "by_feature.0.int_a2_mm2_s3.change",
              "by_layer.0.time_s.after"):
        assert k in keys, k
    for key, unit, value_json, text in page.keyed:
        v = _get(run["data"], key)
        assert json.loads(value_json) == v, key          # full precision, same number
        assert text.strip() == fmt(v, unit), key         # what the reader sees


def test_json_matches_pipeline_summary(run):
    s, d = run["summary"], run["data"]
    h = d["headline"]
    # the report plays the files itself; the pipeline's second pass splices its sums in
    # another order (pipeline.py, partial re-measure): equal to rounding
    same = dict(rel=1e-12)
    assert h["print_time_s"]["before"] == s["print_time_s"]["before"]
    assert h["print_time_s"]["after"] == pytest.approx(s["print_time_s"]["after"], **same)
    assert h["int_a2_whole_mm2_s3"]["before"] == s["whole_file"]["before"]["int_a2"]
    assert h["int_a2_whole_mm2_s3"]["after"] == pytest.approx(s["whole_file"]["after"]["int_a2"], **same)
    assert h["corner_dv2_mm2_s2"]["after"] == pytest.approx(s["whole_file"]["after"]["corner_dv2"], **same)
    assert h["strokes"]["retimed"] == s["strokes"]["retimed"] == len(d["per_stroke"])
    assert h["file"]["bytes"]["after"] == s["file"]["bytes_after"]
    assert h["file"]["lines"]["after"] == s["file"]["lines_after"]
    rt = s["retimed_strokes"]
    assert h["int_a2_retimed_mm2_s3"]["before"] == pytest.approx(rt["int_a2"]["before"], rel=1e-12)
    assert h["int_a2_retimed_mm2_s3"]["after"] == pytest.approx(rt["int_a2"]["after"], rel=1e-12)
    assert h["retimed_time_s"]["after"] == pytest.approx(rt["time_s"]["after"], rel=1e-12)
    assert h["int_v2_retimed_mm2_s"]["after"] == pytest.approx(rt["int_v2"]["after"], rel=1e-12)
    # per stroke: re-derived from the two files (fences) = what the pipeline measured
    for a, b in zip(d["per_stroke"], s["per_stroke"]):
        assert (a["line"], a["out_line"], a["feature"], a["layer"]) == (b["line"], b["out_line"], b["feature"], b["layer"])
        for side in ("before", "after"):
            assert a["time_s"][side] == pytest.approx(b["time_s"][side], rel=1e-12, abs=1e-15)
            assert a["int_a2_mm2_s3"][side] == pytest.approx(b["int_a2"][side], rel=1e-12, abs=1e-9)
        assert a["length_mm"] == pytest.approx(b["length_mm"], abs=1e-4)


def test_report_without_summary_agrees(run):
    p, d = run["plain"], run["data"]
    assert p["schema"] == "gcode-opt-report/1"
    for k in ("print_time_s", "int_a2_retimed_mm2_s3", "int_a2_whole_mm2_s3", "kinetic_whole_J_s",
              "peak_speed_mm_s", "corners", "file"):
        for side in ("before", "after", "change"):
            assert p["headline"][k].get(side) == d["headline"][k].get(side), k
    assert p["headline"]["int_a2_retimed_mm2_s3"]["law"] is None         # the law's figures need the summary
    assert p["headline"]["strokes"]["candidates"] is None       # only the summary knows
    assert len(p["per_stroke"]) == len(d["per_stroke"])
    # the marker's beta (4 digits) gives J to ~1e-3
    assert p["headline"]["J_retimed_J_s"]["after"] == pytest.approx(d["headline"]["J_retimed_J_s"]["after"], rel=1e-3)
    page = _parse(run["plain_html"])
    for key, unit, value_json, text in page.keyed:
        assert json.loads(value_json) == _get(p, key), key


def test_energy_and_J_consistent(run):
    d, prof = run["data"], load_profile(PROFILE)
    h = d["headline"]
    mmin, mmax = min(prof.moving_mass_x_kg, prof.moving_mass_y_kg), max(prof.moving_mass_x_kg, prof.moving_mass_y_kg)
    v2 = h["int_v2_retimed_mm2_s"]["before"] * 1e-6
    assert 0.5 * mmin * v2 <= h["kinetic_retimed_J_s"]["before"] <= 0.5 * mmax * v2
    # whole-file kinetic integral covers the re-timed strokes
    assert h["kinetic_whole_J_s"]["before"] > h["kinetic_retimed_J_s"]["before"]
    # J >= its kinetic part over the same strokes
    J = h["J_retimed_J_s"]
    assert J["after"] > 0 and J["strokes"] <= h["strokes"]["retimed"]


def test_self_contained_and_images_decode(run):
    page = _parse(run["html"])
    for tag, a in page.tags:
        for attr in ("src", "href"):
            v = a.get(attr)
            assert v is None or v.startswith("data:") or v.startswith("#"), (tag, attr, v)
        assert tag not in ("link",) and not (tag == "script" and a.get("src"))
    assert len(page.imgs) >= 4                     # reduction chart, 2 strokes, layer map
    for img in page.imgs:
        src = img["src"]
        assert src.startswith("data:image/png;base64,")
        arr = mpimg.imread(io.BytesIO(base64.b64decode(src.split(",", 1)[1])), format="png")
        assert arr.ndim == 3 and arr.shape[0] > 200 and arr.shape[1] > 400
        assert float(np.std(arr[..., :3])) > 0.02, img.get("alt")          # not blank


def test_fences_pair_original_lines(run):
    fences, n_orig = parse_fences(run["out"])
    with open(SAMPLE, "rb") as fh:
        assert n_orig == sum(1 for _ in fh)
    assert [f.orig_first + 1 for f in fences] == [p["line"] for p in run["summary"]["per_stroke"]]
    with open(run["out"], encoding="utf-8") as fh:
        out = fh.readlines()
    with open(SAMPLE, encoding="utf-8") as fh:
        orig = fh.readlines()
    f = fences[0]
    assert out[f.out_first].startswith("; gcode-opt begin") and out[f.out_last].startswith("; gcode-opt end")
    assert out[f.out_last + 1] == orig[f.orig_last + 1]          # the line after the block is the original's


def test_warnings_and_representatives(run):
    d = run["data"]
    for w in d["warnings"]:
        assert set(w) == {"code", "level", "message", "count", "lines"} and w["level"] in ("warning", "info")
    roles = [r["role"] for r in d["representative"]]
    assert roles[:2] == ["long line", "short line"] and "arc" in roles and "curve" in roles
    arc = next(r for r in d["representative"] if r["role"] == "arc")
    assert arc["line"] is None and "no arcs" in arc["note"]          # this sample has none: said so
    with open(run["html"], encoding="utf-8") as fh:
        assert "the file has no arcs" in fh.read()
    over = [r for r in d["per_stroke"] if r["overshoot"] and r["overshoot"] > 1e-3]
    if over:
        assert any(w["code"] == "speed_overshoot" for w in d["warnings"])


def test_mismatched_files_rejected(run, tmp_path):
    other = tmp_path / "x.gcode"
    other.write_text("G28\nG1 X10 Y10 F3000\n")
    with pytest.raises(ValueError):
        build_report(str(other), run["out"], load_profile(PROFILE))


def test_arc_file_report(tmp_path):
    out, html, js = str(tmp_path / "a.gcode"), str(tmp_path / "a.html"), str(tmp_path / "a.json")
    assert main(["process", ARCS, "-o", out, "--profile", "generic-klipper", "-q"]) == 0
    assert main(["report", ARCS, out, "--profile", "generic-klipper", "-o", html, "--json", js]) == 0
    with open(js) as fh:
        d = json.load(fh)
    arc = next(r for r in d["representative"] if r["role"] == "arc")
    assert arc["line"] is not None
    if arc["retimed"]:            # a re-timed arc is one of the fenced strokes
        assert arc["line"] in [r["line"] for r in d["per_stroke"] if r["kind"] == "arc"]
    page = _parse(html)
    alts = [i.get("alt", "") for i in page.imgs]
    assert any(a.startswith("arc:") for a in alts)
    assert all(math.isfinite(r["time_s"]["after"]) for r in d["per_stroke"])


# --------------------------------------------------------------------------- one story (issue 7 item 10)
MIXED = os.path.join(ROOT, "sample_gcode", "prusa_gyroid_arcs.gcode")     # lines, curves and arcs


@pytest.fixture(scope="module")
def story(tmp_path_factory):
    """process --json --report, then `report` on the same pair with no --profile and no summary."""
    d = tmp_path_factory.mktemp("story")
    out, summ, html = str(d / "o.gcode"), str(d / "s.json"), str(d / "r.html")
    assert main(["process", MIXED, "-o", out, "--json", summ, "--report", html, "-q"]) == 0
    rjson = str(d / "r.json")
    assert main(["report", MIXED, out, "-o", str(d / "r2.html"), "--json", rjson]) == 0
    with open(summ) as fh, open(rjson) as fr:
        return {"dir": d, "out": out, "summary": json.load(fh), "report": json.load(fr), "html": html}


def test_report_resolves_the_profile_like_process(story):
    # printer_model = MK3S: the bundled prusa-mk3s, with the limits the file states ("+file")
    assert story["report"]["profile"] == story["summary"]["profile"] == "prusa-mk3s+file"


def test_report_headline_equals_process_summary(story):
    s, h = story["summary"], story["report"]["headline"]
    assert h["print_time_s"]["before"] == pytest.approx(s["print_time_s"]["before"], rel=1e-12)
    assert h["print_time_s"]["after"] == pytest.approx(s["print_time_s"]["after"], rel=1e-12)
    assert h["int_a2_whole_mm2_s3"]["before"] == pytest.approx(s["whole_file"]["before"]["int_a2"], rel=1e-12)
    assert h["int_a2_whole_mm2_s3"]["after"] == pytest.approx(s["whole_file"]["after"]["int_a2"], rel=1e-12)
    rt = s["retimed_strokes"]
    for side in ("before", "after"):
        assert h["int_a2_retimed_mm2_s3"][side] == pytest.approx(rt["int_a2"][side], rel=1e-9)
        assert h["retimed_time_s"][side] == pytest.approx(rt["time_s"][side], rel=1e-9)
    assert h["strokes"]["retimed"] == s["strokes"]["retimed"]


def test_report_classifies_strokes_as_process(story):
    s, r = story["summary"], story["report"]
    kinds_s = {p["line"]: p["kind"] for p in s["per_stroke"]}
    kinds_r = {p["line"]: p["kind"] for p in r["per_stroke"]}
    assert kinds_r == kinds_s
    assert {"line", "curve", "arc"} <= set(kinds_s.values())          # the sample exercises all three
    by_kind = {g["kind"]: g for g in r["by_kind"]}
    for kind, g in s["retimed_strokes"]["by_kind"].items():
        assert by_kind[kind]["strokes"] == g["retimed"]
        assert by_kind[kind]["int_a2_mm2_s3"]["before"] == pytest.approx(g["int_a2"]["before"], rel=1e-9)
        assert by_kind[kind]["int_a2_mm2_s3"]["after"] == pytest.approx(g["int_a2"]["after"], rel=1e-9)


def test_report_kind_fallback_without_header_kind(story, tmp_path):
    """A processed file whose headers carry no kind= (older versions): the report tells lines,
    curves and arcs apart from the original moves, the same way."""
    import re
    stripped = tmp_path / "old.gcode"
    with open(story["out"], encoding="utf-8") as fh:
        text = fh.read()
    assert "kind=" in text
    stripped.write_text(re.sub(r" kind=\w+,", "", text), encoding="utf-8")
    data, _ = build_report(MIXED, str(stripped), load_profile("prusa-mk3s"))
    kinds = {p["line"]: p["kind"] for p in story["summary"]["per_stroke"]}
    assert {p["line"]: p["kind"] for p in data["per_stroke"]} == kinds


def test_no_stale_curve_caption(story):
    with open(story["html"], encoding="utf-8") as fh:
        page = fh.read()
    assert "not re-timed by this version" not in page
    rep = next(r for r in story["report"]["representative"] if r["role"] == "curve")
    assert rep["retimed"] and rep["line"] in [p["line"] for p in story["summary"]["per_stroke"]
                                              if p["kind"] == "curve"]
