"""Files without feature comments (issue 9 item 4): the run says where its feature labels
came from, and says so on stderr when the selection can re-time no extrusion."""
import os
import re

import pytest

from gcode_opt.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NO_COMMENTS = os.path.join(ROOT, "sample_gcode", "edge", "no_feature_comments.gcode")
WITH_COMMENTS = os.path.join(ROOT, "sample_gcode", "edge", "cura_type.gcode")
# every prefix a slicer uses for its feature comments (Prusa/Orca/Bambu/Cura/Simplify3D)
_FEATURE_LINE = re.compile(r"^\s*;\s*(type:|feature[: ])", re.IGNORECASE)


def _feature_lines(path):
    with open(path, encoding="utf-8") as fh:
        return sum(1 for line in fh if _FEATURE_LINE.match(line))


def _run(capsys, tmp_path, src, *extra):
    out = str(tmp_path / "out.gcode")
    js = str(tmp_path / "s.json")
    rc = main(["process", src, "-o", out, "--json", js, *extra])
    err = capsys.readouterr().err
    import json
    with open(js) as fh:
        return rc, err, json.load(fh)


def test_edge_files_are_what_they_claim():
    # independent of the code under test: the sample really has no feature comments,
    # the control really has some, and the sample does extrude
    assert _feature_lines(NO_COMMENTS) == 0
    assert _feature_lines(WITH_COMMENTS) > 0
    with open(NO_COMMENTS) as fh:
        assert sum(1 for line in fh if line.startswith("G1 ") and " E" in line and "E-" not in line) > 100


def test_no_comments_default_selection_is_said(capsys, tmp_path):
    rc, err, s = _run(capsys, tmp_path, NO_COMMENTS)
    assert rc == 0
    assert s["features"]["source"] == "none"
    assert s["features"]["selected"] == ["sparse_infill", "solid_infill"]
    assert s["strokes"]["retimed"] == 0
    said = [x for x in err.splitlines() if "no feature comments" in x]
    assert len(said) == 1
    assert "sparse_infill,solid_infill" in said[0] and "--features all" in said[0]
    assert said[0].startswith(f"gcode-opt: {NO_COMMENTS}: ")


def test_no_comments_with_all_selected_retimes_extrusion(capsys, tmp_path):
    rc, err, s = _run(capsys, tmp_path, NO_COMMENTS, "--features", "all")
    assert rc == 0
    assert s["features"]["source"] == "none"
    assert "no feature comments" not in err                 # 'other' is selected: nothing to warn about
    assert any(p["feature"] == "other" for p in s["per_stroke"])


def test_file_with_comments_is_silent(capsys, tmp_path):
    rc, err, s = _run(capsys, tmp_path, WITH_COMMENTS)
    assert rc == 0
    assert s["features"] == {"source": "comments", "selected": ["sparse_infill", "solid_infill"]}
    assert "no feature comments" not in err
