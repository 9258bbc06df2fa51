"""Files without feature comments (issue 9 item 4): by default the CLI re-times every
extruding move (`other`) there and says so once; a file with comments keeps the infill
default; an explicit --features is obeyed as given.  Whether a file has feature comments
is checked against an independent line scan."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from gcode_opt import features as feat
from gcode_opt.cli import main

ROOT = Path(__file__).resolve().parents[1]
EDGE_NO = ROOT / "sample_gcode" / "edge" / "no_feature_comments.gcode"
EDGE_YES = ROOT / "sample_gcode" / "edge" / "cura_type.gcode"
SAMPLE_NO = ROOT / "sample_gcode" / "prusa_klipper_no_comments.gcode"
# a full-line comment naming a feature, in any slicer's form (independent of features.py)
_FEATURE_LINE = re.compile(r"^\s*;\s*(type:|feature[: ])", re.IGNORECASE)


def _scan(path):
    with open(path, encoding="utf-8", errors="replace") as fh:
        return any(_FEATURE_LINE.match(line) for line in fh)


def _run(capsys, tmp_path, src, *extra):
    js = tmp_path / "s.json"
    rc = main(["process", str(src), "-o", str(tmp_path / "out.gcode"), "--json", str(js), *extra])
    err = capsys.readouterr().err
    return rc, err, json.loads(js.read_text())


ALL_FILES = sorted((ROOT / "sample_gcode").glob("*.gcode")) + sorted((ROOT / "sample_gcode" / "edge").glob("*.gcode"))


@pytest.mark.parametrize("path", ALL_FILES, ids=lambda p: p.name)
def test_has_feature_comments_agrees_with_a_line_scan(path):
    assert feat.has_feature_comments(path) == _scan(path)


def test_the_bundled_file_without_comments_is_one():
    assert not _scan(SAMPLE_NO) and not _scan(EDGE_NO)
    with open(SAMPLE_NO) as fh:               # and it extrudes a real print's worth
        assert sum(1 for line in fh if line.startswith("G1 ") and " E" in line and "E-" not in line) > 5000


@pytest.mark.parametrize("chunk_b", [7, 64, 1 << 22])
def test_comment_across_a_chunk_boundary_is_found(tmp_path, chunk_b):
    p = tmp_path / "f.gcode"
    p.write_bytes(b"G1 X1 Y1\n" * 5 + b";TYPE:Internal infill\n" + b"G1 X2 Y2 E1\n")
    assert feat.has_feature_comments(p, chunk_b=chunk_b)
    q = tmp_path / "g.gcode"
    q.write_bytes(b"G1 X1 Y1 ; TYPE: not a full-line comment\n" * 20 + b"M117 ;type\n")
    assert not feat.has_feature_comments(q, chunk_b=chunk_b)


def test_default_on_a_file_without_comments_retimes_extrusion_and_says_why(capsys, tmp_path):
    rc, err, s = _run(capsys, tmp_path, EDGE_NO)
    assert rc == 0
    fi = s["features"]
    assert fi["source"] == "none" and fi["selected"] == [feat.OTHER]
    assert "no feature comments" in fi["why"]
    said = [x for x in err.splitlines() if "no feature comments" in x]
    assert said == [f"gcode-opt: {EDGE_NO}: {feat.NO_COMMENTS_WHY}"]
    assert s["strokes"]["retimed"] > 0
    assert {p["feature"] for p in s["per_stroke"]} == {feat.OTHER}       # extrusion, never travel


def test_explicit_features_are_obeyed_in_a_file_without_comments(capsys, tmp_path):
    rc, err, s = _run(capsys, tmp_path, EDGE_NO, "--features", "sparse_infill,solid_infill")
    assert rc == 0
    assert "why" not in s["features"] and s["strokes"]["retimed"] == 0
    note = [x for x in err.splitlines() if "no feature comments" in x]
    assert len(note) == 1 and "--features all" in note[0]    # the pipeline's note: nothing re-timed


def test_file_with_comments_keeps_the_infill_default(capsys, tmp_path):
    rc, err, s = _run(capsys, tmp_path, EDGE_YES)
    assert rc == 0
    assert s["features"]["source"] == "comments" and "why" not in s["features"]
    assert s["features"]["selected"] == list(feat.DEFAULT_SELECTED)
    assert "no feature comments" not in err


def test_quiet_says_nothing_but_json_keeps_why(capsys, tmp_path):
    rc, err, s = _run(capsys, tmp_path, EDGE_NO, "-q")
    assert rc == 0 and "no feature comments" not in err
    assert s["features"]["why"] == feat.NO_COMMENTS_WHY


@pytest.mark.slow
def test_real_file_without_comments_gains(capsys, tmp_path):
    # the bundled boat sliced for Klipper with ;TYPE: removed: 0 % before issue 9 item 4
    rc, err, s = _run(capsys, tmp_path, SAMPLE_NO)
    assert rc == 0 and s["features"]["selected"] == [feat.OTHER]
    assert s["whole_file"]["int_a2_change"] < -0.10
    assert s["whole_file"]["after"]["full_stops"] <= s["whole_file"]["before"]["full_stops"]
