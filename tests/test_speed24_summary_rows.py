"""The summary's per-stroke rows are built only where something reads them (--json, --report):
without them the summary is the same, less its per_stroke list, and the command line's text
and G-code are the same bytes."""
import json
import os

from gcode_opt import cli, pipeline
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")

VOLATILE = ("elapsed_s", "timing_s", "input", "output")


def _summary(path, prof, tmp_path, rows, tag):
    opts = pipeline.Options()
    opts.summary_rows = rows
    return pipeline.process(path, str(tmp_path / f"{tag}.gcode"), load_profile(prof), opts)


def test_summary_without_rows_is_the_summary_less_its_rows(tmp_path):
    for name, prof in (("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24")):
        path = os.path.join(SAMPLES, name)
        full = _summary(path, prof, tmp_path, True, "full")
        bare = _summary(path, prof, tmp_path, False, "bare")
        assert (tmp_path / "full.gcode").read_bytes() == (tmp_path / "bare.gcode").read_bytes()
        assert "per_stroke" not in bare and len(full["per_stroke"]) == full["strokes"]["retimed"] > 0
        for k in VOLATILE:
            full.pop(k, None)
            bare.pop(k, None)
        full.pop("per_stroke")
        # by_kind, coverage, whole-file figures, ringing: all of it, to the bit
        assert json.dumps(full, sort_keys=True) == json.dumps(bare, sort_keys=True)


def test_command_line_text_is_the_same_with_and_without_json(tmp_path, capsys):
    src = os.path.join(SAMPLES, "prusa_concentric_arcs.gcode")
    texts, outs = [], []
    for tag, extra in (("plain", []), ("json", ["--json", str(tmp_path / "s.json")])):
        out = tmp_path / f"{tag}.gcode"
        assert cli.main(["process", src, "-o", str(out), "--profile", "voron24", *extra]) == 0
        texts.append(capsys.readouterr().err.replace(str(out), "OUT"))
        outs.append(out.read_bytes())
    assert texts[0] == texts[1] and "int|a|^2 dt" in texts[0]
    assert outs[0] == outs[1]
    rows = json.loads((tmp_path / "s.json").read_text())["per_stroke"]
    assert rows and {"line", "kind", "time_s", "int_a2", "beta_s2"} <= set(rows[0])
