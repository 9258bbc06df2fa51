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


def test_no_comments_infill_selection_is_said(capsys, tmp_path):
    # an explicit infill-only selection is obeyed on a comment-less file (the default
    # there re-times every extruding move: tests/test_cli_no_comments.py), and said
    rc, err, s = _run(capsys, tmp_path, NO_COMMENTS, "--features", "sparse_infill,solid_infill")
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


# ---- the geometric fallback (classify.py), checked against the slicer's own comments
PERIMETERS = {"perimeter", "external_perimeter", "overhang_perimeter", "skirt"}
INFILL = {"sparse_infill", "solid_infill"}


def _moves(path):
    from gcode_opt.profile import load_profile
    from gcode_opt.state import MachineState, Move, read_lines
    st = MachineState(load_profile("generic-klipper"), path)
    for idx, raw in read_lines(path):
        ev = st.step(idx, raw)
        for m in (ev if isinstance(ev, list) else [ev]):
            if isinstance(m, Move):
                yield m


@pytest.mark.parametrize("name", ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid.gcode"])
def test_loops_are_the_perimeters(name):
    from gcode_opt.classify import LOOP, run_label, runs
    conf = {}
    for r in runs(_moves(os.path.join(ROOT, "sample_gcode", name))):
        lab = run_label(r)
        for m in r:
            conf[(m.feature, lab)] = conf.get((m.feature, lab), 0) + 1
    per = sum(v for (f, lab), v in conf.items() if f in PERIMETERS)
    inf = sum(v for (f, lab), v in conf.items() if f in INFILL)
    assert per > 100 and inf > 100
    assert sum(v for (f, lab), v in conf.items() if f in PERIMETERS and lab != LOOP) == 0
    assert sum(v for (f, lab), v in conf.items() if f in INFILL and lab == LOOP) == 0


def test_seam_gap_is_why_the_tolerance_is_not_0_05():
    # PrusaSlicer leaves a 0.06 mm seam gap: at 0.05 mm no perimeter would close
    from gcode_opt.classify import LOOP, run_label, runs
    rs = [r for r in runs(_moves(os.path.join(ROOT, "sample_gcode", "prusa_mk3s_rectilinear.gcode")))
          if r[0].feature == "external_perimeter"]
    assert rs and all(run_label(r) == LOOP for r in rs)
    assert not any(run_label(r, tol_d=0.05) == LOOP for r in rs)
