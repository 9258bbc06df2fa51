"""Command-line errors (issue 7 item 8): every user error exits 2 with one line
`gcode-opt: <path or option>: why`, no traceback, the input's bytes unchanged and no
temporary file left; --debug shows the traceback."""
import os
import shutil
import subprocess
import sys

import pytest

from gcode_opt.cli import build_parser, main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLE = os.path.join(ROOT, "sample_gcode", "prusa_absolute_e.gcode")


@pytest.fixture
def src(tmp_path):
    p = tmp_path / "in.gcode"
    shutil.copyfile(SAMPLE, p)
    return str(p)


def _bytes(p):
    with open(p, "rb") as fh:
        return fh.read()


def _run(capsys, args):
    rc = main(args)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [x for x in err.splitlines() if x.startswith("gcode-opt: ") and not x.startswith("gcode-opt: profile ")]
    return rc, lines


def _clean(folder):
    assert not [n for n in os.listdir(folder) if n.startswith(".gcode-opt-")]


def _bad_profile(tmp_path, text):
    f = tmp_path / "my.toml"
    f.write_text(text)
    return str(f)


def test_missing_input(capsys, tmp_path):
    p = str(tmp_path / "nope.gcode")
    rc, lines = _run(capsys, ["process", p])
    assert rc == 2 and lines == [f"gcode-opt: {p}: no such file"]
    rc, lines = _run(capsys, ["simulate", p])
    assert rc == 2 and lines == [f"gcode-opt: {p}: no such file"]
    rc, lines = _run(capsys, ["report", p, SAMPLE])
    assert rc == 2 and lines == [f"gcode-opt: {p}: no such file"]


def test_directory_input(capsys, tmp_path):
    rc, lines = _run(capsys, ["process", str(tmp_path)])
    assert rc == 2 and lines == [f"gcode-opt: {tmp_path}: is a directory: give a G-code file"]


@pytest.mark.parametrize("prof,expect", [
    ("nosuch.toml", "gcode-opt: nosuch.toml: no such profile file; bundled profiles: "),
    ("nosuch", "gcode-opt: no profile named 'nosuch'; bundled: "),
])
def test_unknown_profile(capsys, src, prof, expect):
    rc, lines = _run(capsys, ["process", src, "--profile", prof])
    assert rc == 2 and len(lines) == 1 and lines[0].startswith(expect)
    assert "generic-klipper" in lines[0] and "prusa-mk3s" in lines[0]        # lists the bundled ones
    assert _bytes(src) == _bytes(SAMPLE)


def test_invalid_profile_names_file_and_key(capsys, src, tmp_path):
    f = _bad_profile(tmp_path, '[firmware]\nflavour = "klipper"\njunction = "scv"\nsquare_corner_velocity_v = 5\n'
                               '[limits]\nmax_velocity_v = 300\nmax_accel_a = -1000\n')
    rc, lines = _run(capsys, ["process", src, "--profile", f])
    assert rc == 2 and lines == [f"gcode-opt: {f}: max_accel_a = -1000: must be > 0 mm/s^2"]
    assert _bytes(src) == _bytes(SAMPLE)
    _clean(tmp_path)


def test_empty_profile_refused(capsys, src, tmp_path):
    f = _bad_profile(tmp_path, "")
    rc, lines = _run(capsys, ["process", src, "--profile", f])
    assert rc == 2 and len(lines) == 1 and lines[0].startswith(f"gcode-opt: {f}: empty profile")


@pytest.mark.parametrize("opt", ["--max-slowdown", "--overshoot"])
def test_fraction_above_one_refused_with_hint(capsys, src, opt):
    with pytest.raises(SystemExit) as ei:
        main(["process", src, opt, "3"])
    assert ei.value.code == 2
    err = capsys.readouterr().err
    assert f"gcode-opt: {opt}: 3: " in err and "did you mean 3%?" in err
    assert "_fraction" not in err and "Traceback" not in err
    assert _bytes(src) == _bytes(SAMPLE)


@pytest.mark.parametrize("text,value", [("3%", 0.03), ("0.25", 0.25), ("25 %", 0.25), ("0", 0.0), ("1", 1.0)])
def test_fraction_forms_accepted(text, value):
    a = build_parser().parse_args(["process", "x.gcode", "--max-slowdown", text, "--overshoot", text])
    assert a.max_slowdown == pytest.approx(value) and a.overshoot == pytest.approx(value)


@pytest.mark.parametrize("args,needle", [
    (["--segments", "0"], "--segments: 0: must be >= 1"),
    (["--segments", "2.5"], "--segments: '2.5': expected a whole number"),
    (["--max-turn", "90"], "--max-turn: 90: must be in [0, 90)"),
    (["--max-turn", "-1"], "--max-turn: -1: must be in [0, 90)"),
    (["--min-length", "-1"], "--min-length: -1: must be >= 0"),
    (["--min-length", "nan"], "--min-length: 'nan': must be a finite number"),
    (["--alpha", "inf"], "--alpha: 'inf': must be a finite number"),
    (["--alpha", "-1"], "--alpha: -1: alpha must be > 0"),
    (["--alpha", "fast"], "--alpha: 'fast' is not a number"),
    (["--overshoot", "-0.1"], "--overshoot: -0.1: must be >= 0"),
    (["--overshoot", "x%"], "--overshoot: 'x' is not a number"),
    (["--max-slowdown", "150%"], "--max-slowdown: 150%: a fraction above 1"),
])
def test_numeric_options_checked(capsys, src, args, needle):
    with pytest.raises(SystemExit) as ei:
        main(["process", src, *args])
    assert ei.value.code == 2
    err = capsys.readouterr().err
    assert f"gcode-opt: {needle}" in err, err
    assert "Traceback" not in err and "invalid" not in err      # no "invalid _x value" from argparse
    assert _bytes(src) == _bytes(SAMPLE)


@pytest.mark.parametrize("which", ["-o", "--report", "--json"])
def test_output_paths_checked_first(capsys, src, tmp_path, which):
    missing = str(tmp_path / "no" / "such" / "out.x")
    rc, lines = _run(capsys, ["process", src, which, missing, "-q"])
    assert rc == 2 and lines == [f"gcode-opt: {missing}: folder {os.path.dirname(missing)} does not exist"]
    rc, lines = _run(capsys, ["process", src, which, str(tmp_path), "-q"])
    assert rc == 2 and len(lines) == 1 and lines[0].startswith(f"gcode-opt: {tmp_path}: is a directory")
    assert _bytes(src) == _bytes(SAMPLE)
    _clean(tmp_path)


def test_same_file_for_two_outputs_refused(capsys, src, tmp_path):
    out = str(tmp_path / "o.gcode")
    rc, lines = _run(capsys, ["process", src, "-o", out, "--json", out, "-q"])
    assert rc == 2 and "named both as the output and the summary" in lines[0]


def test_reader_error_names_file_and_line(capsys, tmp_path):
    p = tmp_path / "bad.gcode"
    body = "G21\nG90\nM83\nG1 X10 Y10 F3000\nG2 X20 Y10\nG1 X30 Y30 E1\n"     # an arc with no centre
    p.write_text(body)
    rc, lines = _run(capsys, ["process", str(p), "-q", "--profile", "generic-klipper"])
    assert rc == 2 and len(lines) == 1 and lines[0].startswith(f"gcode-opt: {p}:5: ")
    assert p.read_text() == body
    _clean(tmp_path)


def test_interrupt_is_one_line_exit_130(capsys, src, monkeypatch, tmp_path):
    from gcode_opt import pipeline

    def ctrl_c(*a, **k):
        raise KeyboardInterrupt
    monkeypatch.setattr(pipeline, "measure", ctrl_c)        # after the rewrite pass has begun
    rc, lines = _run(capsys, ["process", src, "-q", "--profile", "prusa-mk3s"])
    assert rc == 130 and lines == [f"gcode-opt: interrupted; {src} left unchanged"]
    assert _bytes(src) == _bytes(SAMPLE)
    _clean(tmp_path)


def test_internal_error_one_line_and_debug_traceback(capsys, src, monkeypatch, tmp_path):
    from gcode_opt import pipeline

    def bug(*a, **k):
        raise ZeroDivisionError("float division by zero")
    monkeypatch.setattr(pipeline, "plan_inputs", bug)
    rc, lines = _run(capsys, ["process", src, "-q", "--profile", "prusa-mk3s"])
    assert rc == 1 and len(lines) == 1
    assert "internal error: ZeroDivisionError" in lines[0] and "--debug" in lines[0]
    assert lines[0].endswith(f"{src} left unchanged")
    assert main(["process", src, "-q", "--profile", "prusa-mk3s", "--debug"]) == 1
    assert "Traceback" in capsys.readouterr().err
    assert _bytes(src) == _bytes(SAMPLE)
    _clean(tmp_path)


def test_as_a_program(tmp_path):
    """The real entry point, in a fresh interpreter: exit status and stderr as a user sees them."""
    p = str(tmp_path / "missing.gcode")
    r = subprocess.run([sys.executable, "-m", "gcode_opt.cli", "process", p], capture_output=True, text=True,
                       cwd=ROOT, timeout=60)
    assert r.returncode == 2 and r.stderr == f"gcode-opt: {p}: no such file\n"
    r = subprocess.run([sys.executable, "-m", "gcode_opt.cli", "process", p, "--max-slowdown", "3"],
                       capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "did you mean 3%?" in r.stderr
    # errors raised from the sub-command modules (report, law) are the same classes as main's
    for args in (["report", p, SAMPLE], ["law", "--gcode", p, "--line-number", "3", "--beta", "0.1"],
                 ["law", "--line", "0,0,1,1", "--beta", "0.1", "-o", str(tmp_path / "no" / "t.csv")]):
        r = subprocess.run([sys.executable, "-m", "gcode_opt.cli", *args], capture_output=True, text=True,
                           cwd=ROOT, timeout=60)
        assert r.returncode == 2 and r.stderr.startswith("gcode-opt: ") and "internal error" not in r.stderr, args


def test_binary_input_refused(capsys, tmp_path):
    pytest.importorskip("gcode_opt.inputcheck", reason="helper A's input check not in this tree yet")
    p = tmp_path / "part.bgcode"
    data = b"GCDE\x01\x00\x00\x00" + bytes(range(256)) * 4
    p.write_bytes(data)
    rc, lines = _run(capsys, ["process", str(p), "-q"])
    assert rc == 2 and len(lines) == 1 and lines[0].startswith(f"gcode-opt: {p}")
    assert p.read_bytes() == data
    _clean(tmp_path)


def test_reader_warnings_name_their_line_and_reach_the_summary(capsys, tmp_path):
    # edge/arc_variants.gcode line 13: an arc whose end is 0.05 mm off its circle (left as written)
    src = os.path.join(ROOT, "sample_gcode", "edge", "arc_variants.gcode")
    out, js = tmp_path / "o.gcode", tmp_path / "s.json"
    rc = main(["process", src, "-o", str(out), "--json", str(js), "--profile-time"])
    err = capsys.readouterr().err
    assert rc == 0 and "Traceback" not in err
    assert f"gcode-opt: {src}:13: warning: arc end 0.050 mm off its circle" in err
    assert "CPU time (s)" in err and "analyse" in err
    import json
    from gcode_opt import state
    from gcode_opt.firmware import simulate
    from gcode_opt.laws import chain as chain_law
    from gcode_opt import emit
    from gcode_opt.laws import circle
    assert (f"cores: firmware model {simulate.CORE}, reader {state.CORE}, chains {chain_law.CORE}, "
            f"rewrite {emit.CORE}, curves {circle.CORE}") in err   # c or python
    assert json.loads(js.read_text())["firmware_core"] == simulate.CORE
    assert json.loads(js.read_text())["reader_core"] == state.CORE
    assert json.loads(js.read_text())["chain_core"] == chain_law.CORE
    assert json.loads(js.read_text())["emit_core"] == emit.CORE
    assert json.loads(js.read_text())["curve_core"] == circle.CORE
    w = json.loads(js.read_text())["warnings"]
    assert w["count"] == 1 and w["first"][0]["line"] == 13
