"""The report leads with the whole file (issue 9 item 5): its coverage section, derived from
the report's own trace of the two files and their fences, agrees with the pipeline's
summary (derived in the analyse pass), and comes before everything but the key figures."""
from __future__ import annotations

import json
import os

import pytest

from gcode_opt.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLE = os.path.join(ROOT, "sample_gcode", "prusa_mk3s_rectilinear.gcode")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("report-coverage")
    out, js, html, rjs = d / "o.gcode", d / "s.json", d / "r.html", d / "r.json"
    assert main(["process", SAMPLE, "-o", str(out), "--profile", "prusa-mk3s", "--json", str(js),
                 "--report", str(html), "-q"]) == 0
    assert main(["report", SAMPLE, str(out), "--profile", "prusa-mk3s", "-o", str(d / "r2.html"),
                 "--json", str(rjs)]) == 0
    return {"summary": json.loads(js.read_text()), "html": html.read_text(encoding="utf-8"),
            "report": json.loads(rjs.read_text())}


def test_report_shares_agree_with_the_summary(run):
    s, r = run["summary"]["coverage"], run["report"]["coverage"]
    assert r["retimed"]["strokes"] == s["retimed"]["strokes"]
    assert r["retimed"]["int_a2_share"] == pytest.approx(s["retimed"]["int_a2_share"], rel=1e-9)
    assert r["retimed"]["time_share"] == pytest.approx(s["retimed"]["time_share"], rel=1e-9)
    assert r["whole_file"]["int_a2_change"] == pytest.approx(s["whole_file"]["int_a2_change"], abs=1e-12)


def test_report_left_by_feature_adds_up(run):
    r = run["report"]["coverage"]
    total = r["retimed"]["int_a2_share"] + sum(g["int_a2_share"] for g in r["left_by_feature"])
    assert total == pytest.approx(1.0, abs=1e-9)
    feats = {g["feature"]: g for g in r["left_by_feature"]}
    assert "travel" in feats and "perimeter" in feats
    # without the pipeline's summary the report does not know the selection nor the reasons
    assert feats["travel"]["selected"] is None and r["left_by_reason"] is None


def test_report_with_summary_names_selection_and_reasons(run):
    h = run["html"]
    lead = h[h.index("The whole file: what was re-timed"):h.index("<h2>Warnings</h2>")]
    assert "travel (not selected)" in lead and "perimeter (not selected)" in lead
    assert "Left as sliced, because" in lead


def test_html_leads_with_the_whole_file(run):
    h = run["html"]
    lead = h.index("The whole file: what was re-timed")
    assert lead < h.index("<h2>Warnings</h2>") < h.index("<h2>Headline</h2>")
    first_kpi = h.index('class="kpi"')
    assert 'data-key="headline.int_a2_whole_mm2_s3.change"' in h[first_kpi:first_kpi + 200]
    share = run["summary"]["coverage"]["retimed"]["int_a2_share"]
    assert f"{share * 100:.1f} %" in h[lead:lead + 2000]
