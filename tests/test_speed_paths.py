"""The fast paths of issue 8 (speed) give what the slow ones gave.

Each fast path is checked against an independent reading: the machine state replayed line
by line, plain float formatting, the validator's generic grammar, the reader's strict
tokenizer, stroke grouping without the short-run shortcut.
"""
import math
import random

import pytest

from gcode_opt import curves, emit, state, validate
from gcode_opt import features as feat
from gcode_opt.pipeline import Options, analyse, process
from gcode_opt.profile import load_profile
from gcode_opt.state import MachineState, events, read_lines
from gcode_opt.strokes import group_strokes
from gcode_opt.verify import verify

SAMPLES = "sample_gcode/"


@pytest.mark.parametrize("name,prof", [("prusa_absolute_e.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3"), ("prusa_gyroid_arcs.gcode", "voron24")])
def test_stroke_start_state_is_the_readers_state(name, prof):
    """rewrite no longer replays the machine state: what analyse recorded at each stroke's
    start must be exactly the state a replay has before the stroke's first line."""
    profile = load_profile(prof)
    strokes, _ = analyse(SAMPLES + name, profile, Options())
    assert strokes
    first = {s.first_idx: s for s in strokes}
    st = MachineState(profile, name)
    seen = 0
    for idx, raw in read_lines(SAMPLES + name):
        s = first.get(idx)
        if s is not None:
            want = (st.e, st.accel_for(s.feature != feat.TRAVEL, True), st.lim.mcr)
            assert s.start_state == want, (idx, s.start_state, want)
            assert (s.x0, s.y0) == (st.x, st.y)
            seen += 1
        st.step(idx, raw)
    assert seen == len(strokes)


def test_short_run_shortcut_drops_only_what_the_length_filter_dropped():
    profile = load_profile("prusa-mk3s")
    path = SAMPLES + "prusa_gyroid.gcode"
    split = curves.vertex_splitter(profile)

    def strokes(min_d):
        return [(s.first_idx, s.last_idx, s.length_d, s.kind)
                for kind, *rest in group_strokes(events(path, profile), feat.DEFAULT_SELECTED, min_d, 30.0, split)
                if kind == "stroke" for s in rest]

    every = strokes(0.0)
    kept = strokes(2.0)
    assert kept == [s for s in every if s[2] >= 2.0]
    assert len(kept) < len(every)           # the sample has short runs: the shortcut ran


def _float_text(u, dec):
    """Independent reference: the float formatting the emitter used before."""
    t = f"{u / 10 ** dec:.{dec}f}"
    if "." in t:
        t = t.rstrip("0").rstrip(".")
    return "0" if t in ("-0", "") else t


def test_integer_unit_formatting_is_the_float_formatting():
    rng = random.Random(8)
    cases = [(0, 3), (-1, 3), (5, 5), (-5, 5), (1000, 3), (-1000, 3), (123456789, 5), (10 ** 12, 5), (7, 0)]
    for _ in range(50000):
        dec = rng.randint(0, 8)
        cases.append((rng.choice([rng.randint(-999, 999), rng.randint(-10 ** 12, 10 ** 12)]), dec))
    for u, dec in cases:
        assert emit._fmt_units(u, dec) == _float_text(u, dec), (u, dec)


@pytest.mark.parametrize("text,value", [("0.1884", 0.1884), ("6000", 6000.0), ("1234.5678", 1234.5678),
                                        ("0.00001", 1e-05), ("18000", 18000.0), ("2.5", 2.5)])
def test_restored_feed_is_the_feed_in_force(text, value):
    """tests/cases/feed_restore_rounded.gcode: F0.1884 came back as F0.188.  The restore
    sees the feed in mm/s (F / 60) and writes mm/min."""
    lines = emit._closing("marlin2", 1000.0, True, 0.0, value / 60.0, "\n")
    f_line = [l for l in lines if l.startswith("G1 F")][0]
    assert f_line == f"G1 F{text}\n"
    assert float(f_line[4:]) == pytest.approx(value, rel=1e-12)


G1_LINES = ["G1 X10.5 Y2.25 E0.01 F1200", "G1 X10.5 Y2.25 F1200", "G1 X-0.5 Y.25 E-.1 F30.5",
            "G1 X10.123456789 Y2 E1 F100", "G1 X1e1 Y2 E1 F100", "G1 X10.5 Y2.25 E0.01 F0", "G1 X10.5 Y2.25 E0.01 F-5",
            "G1 X10.5 Y2.25 E0.01", "G1 X10.5 E0.01 F100", "G1 X50 Y50 E1 F100", "G1 X10 Y2 E1 F100 ; c",
            "G1 Y2 X10 E1 F100", "G1 X10 Y2 E1 E2 F100", "G1 X+10 Y2 E1 F100", "G1 X10. Y2 E1 F100",
            "G1 X10 Y2.000000000 F100", "G1 X10 Y2 E1 F" + "9" * 400]


@pytest.mark.parametrize("line", G1_LINES)
def test_validator_fast_path_gives_the_generic_verdict(line, monkeypatch):
    def verdict():
        text = f"{validate.BEGIN}: replaces 1 lines, kind=line\nM204 S1000\n{line}\n{validate.END}\n"
        geo = validate.Geometry([(0.0, 0.0), (20.0, 4.5)])
        try:
            validate.validate_block(text, "klipper", 3000.0, geo)
            return "ok"
        except validate.BlockInvalid as e:
            return "invalid" if "not finite" not in str(e) else "not finite"

    fast = verdict()
    monkeypatch.setattr(validate, "_G1_PLAIN", lambda code: None)     # the generic grammar only
    assert fast == verdict()


@pytest.mark.parametrize("line", ["M204 S1500", "M204 P800 T3000", "M204 S1e3", "M204 S-5", "M204 S0",
                                  "M204 P500", "M204 T2000 R1000", "M204 S.5", "M204 S1.2.3", "M204 S100 S200",
                                  "M204 S+250", "M204 S1500 ; comment"])
@pytest.mark.parametrize("flavour", ["klipper", "marlin2", "marlin-legacy"])
def test_reader_m204_fast_path_is_the_strict_reading(line, flavour, monkeypatch):
    import dataclasses
    prof = dataclasses.replace(load_profile("generic-klipper"), flavour=flavour)

    def reading():
        st = MachineState(prof)
        try:
            st.step(0, line + "\n")
        except state.GcodeError as e:
            return ("error", str(e))
        return (st.accel_print, st.accel_travel, st.accel_retract)

    fast = reading()
    monkeypatch.setattr(state, "_fast_m204", lambda code: None)
    assert fast == reading()


def test_rewrite_copies_a_file_that_ends_inside_nothing_and_without_newline(tmp_path):
    """Bulk copy: CRLF lines, a last line without a newline, after the last stroke."""
    body = ["M83", "G21", "G90", ";TYPE:Internal infill", "G1 X10 Y10 F9000", "G1 F4800"]
    x = 10.0
    for k in range(12):
        x2 = x + 40.0 if k % 2 == 0 else x - 40.0
        body += [f"G1 X{x2:.3f} Y{10 + k:.3f} E1.5", f"G1 X{x2:.3f} Y{11 + k:.3f} E0.04"]
        x = x2
    text = "\r\n".join(body + [";TYPE:Custom", "M107", "; the end"])      # no final newline
    src = tmp_path / "in.gcode"
    src.write_bytes(text.encode())
    dst = tmp_path / "out.gcode"
    s = process(str(src), str(dst), load_profile("prusa-mk3s"), Options())
    assert s["strokes"]["retimed"] > 0
    verify(str(src), str(dst), load_profile("prusa-mk3s"))
    assert dst.read_bytes().endswith(b"\r\nM107\r\n; the end")


def test_process_reports_cpu_time_per_phase(tmp_path):
    import time
    t0 = time.process_time()
    s = process(SAMPLES + "prusa_absolute_e.gcode", str(tmp_path / "o.gcode"), load_profile("prusa-mk3s"),
                Options())
    spent = time.process_time() - t0
    t = s["timing_s"]
    phases = ("analyse", "plan", "rewrite", "measure", "summary")
    assert set(t) == set(phases) | {"total"}
    assert all(t[k] >= 0.0 for k in t)
    assert math.isclose(sum(t[k] for k in phases), t["total"], rel_tol=1e-9, abs_tol=1e-9)
    assert t["total"] <= spent + 1e-6
    assert s["rewrite_passes"] in (1, 2)


@pytest.mark.parametrize("data", [b"", b"a", b"a\n", b"a\nb", b"a\r\nb\r\n", b"\n\n", b"x" * (3 << 20) + b"\ny"])
def test_line_count_is_the_count_of_binary_iteration(tmp_path, data):
    from gcode_opt.summary import count_lines
    f = tmp_path / "f"
    f.write_bytes(data)
    with open(f, "rb") as fh:
        assert count_lines(str(f)) == sum(1 for _ in fh)


@pytest.mark.parametrize("m204", ["M204 S1000", "M204 P1000", "M204 T1000", "M204 S0", "M204 S-5", "M204 S3000.1",
                                  "M204 S3000.2", "M204 S1e3", "M204 S1.123456789", "M204 s1000", "M204 S" + "9" * 400,
                                  "M204 S1000 P1000", "M204 X1000"])
@pytest.mark.parametrize("flavour,extruding", [("klipper", True), ("marlin2", True), ("marlin2", False),
                                               ("marlin-legacy", True)])
def test_validator_m204_fast_path_gives_the_generic_verdict(m204, flavour, extruding, monkeypatch):
    def verdict():
        text = f"{validate.BEGIN}: replaces 1 lines, kind=line\n{m204}\nG1 X10 Y2 E1 F100\n{validate.END}\n"
        try:
            validate.validate_block(text, flavour, 3000.0, None, extruding=extruding)
            return "ok"
        except validate.BlockInvalid as e:
            return "invalid" if "not finite" not in str(e) else "not finite"

    fast = verdict()
    monkeypatch.setattr(validate, "_M204_PLAIN", lambda code: None)
    assert fast == verdict()
