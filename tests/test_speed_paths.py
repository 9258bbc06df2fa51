"""The fast paths of issue 8 (speed) give what the slow ones gave.

Each fast path is checked against an independent reading: the machine state replayed line
by line, plain float formatting, the validator's generic grammar, the reader's strict
tokenizer, stroke grouping without the short-run shortcut.
"""
import math
import os
import random

import numpy as np
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
    phases = ("analyse", "plan", "rewrite", "measure", "ringing", "summary")
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


# ---------------------------------------------------------------- partial re-measure (issue 8)
from gcode_opt import pipeline  # noqa: E402
from gcode_opt.firmware import simulate as fsim  # noqa: E402

CORPUS = os.path.join(os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "gcode-opt-corpus")


def _same_result(got, want, rel=1e-9):
    """SimResult figures: counts and stop lines exact, sums to `rel` (a splice adds them in
    another order), peaks exact (a max)."""
    a, b = got.as_dict(), want.as_dict()
    assert a.keys() == b.keys()
    for k, v in b.items():
        if isinstance(v, float) and k not in ("peak_v", "peak_a"):
            assert a[k] == pytest.approx(v, rel=rel, abs=1e-300), k
        else:
            assert a[k] == v, k


def _split_some_moves(src, dst, every):
    """A copy of src with every `every`-th plain extruding "G1 X Y E" cut in two lines at
    its middle (relative E: the halves carry the E between them, to the last decimal);
    returns how many."""
    n = 0
    with open(src, newline="") as fi, open(dst, "w", newline="") as fo:
        st = MachineState(load_profile("prusa-mk3s"), src)
        k = 0
        for idx, raw in enumerate(fi):
            x0, y0 = st.x, st.y
            ev = st.step(idx, raw)
            toks = raw.split(";")[0].split()
            if (ev is not None and type(ev) is state.Move and ev.kind == state.LINE and ev.e > 0 and ev.e_rel
                    and len(toks) == 4 and toks[0] == "G1" and [t[0] for t in toks[1:]] == ["X", "Y", "E"]):
                k += 1
                if k % every == 0:
                    xm, ym = 0.5 * (x0 + ev.x1), 0.5 * (y0 + ev.y1)
                    units = round(ev.e * 1e5)          # the slicer's 5 decimals, cut in two exactly
                    fo.write(f"G1 X{xm:.4f} Y{ym:.4f} E{units // 2 / 1e5:.5f}\n")
                    fo.write(f"G1 X{ev.x1:.4f} Y{ev.y1:.4f} E{(units - units // 2) / 1e5:.5f}\n")
                    n += 1
                    continue
            fo.write(raw)
    return n


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
                                       ("prusa_mk3s_rectilinear.gcode", "ender3")])
def test_replayed_stretches_give_the_full_pass(name, prof, tmp_path):
    """A file changed inside some lines (moves cut in two: more lines, other junctions),
    measured by replaying only the stretches around the changes from a ledger of the
    original, gives what the firmware model gives on the whole changed file."""
    profile = load_profile(prof)
    src = SAMPLES + name
    dst = str(tmp_path / "changed.gcode")
    n_split = _split_some_moves(src, dst, 300)
    assert n_split > 5
    # the changes, as line ranges of both files: every split line becomes two
    old_ranges, new_ranges = [], []
    with open(src, newline="") as fa:
        old = fa.readlines()
    with open(dst, newline="") as fb:
        new = fb.readlines()
    i = j = 0
    while i < len(old):
        if old[i] == new[j]:
            i, j = i + 1, j + 1
        else:
            old_ranges.append((i, i))
            new_ranges.append((j, j + 1))
            i, j = i + 1, j + 2
    assert len(old_ranges) == n_split and j == len(new)
    res1, led = fsim.simulate_ledger(src, profile, old_ranges)
    _same_result(res1, fsim.simulate_file(src, profile), rel=0.0)      # the ledger pass is the plain pass
    # stretches: the ledger's stops around each change, merged, renumbered into the new file
    runs, shift = [], 0
    for w, ((a, _), (b, z)) in enumerate(zip(old_ranges, new_ranges)):
        lo, hi = led.lo[w], led.hi[w]
        if runs and lo < runs[-1][1]:
            runs[-1][1] = max(runs[-1][1], hi)
            runs[-1][2] += 1
        else:
            runs.append([lo, hi, 1])
    spans = []
    for lo, hi, d in runs:
        spans.append((lo, hi, led.line[lo] + 1 + shift, led.line[hi] + shift + d))
        shift += d
    assert len(spans) > 2
    got, played = fsim.replay_runs(dst, profile, led, spans)
    _same_result(got, fsim.simulate_file(dst, profile))
    n_played = sum(led.line[hi] - led.line[lo] for lo, hi in played)
    print(f"played {n_played} of {len(old)} lines")
    assert n_played < 0.8 * len(old)        # the point: most of the file is not played again


def test_replay_goes_on_while_the_reader_state_differs(tmp_path):
    """A change that leaves the reader in another state after its stretch (here an M221
    the original did not have: every later extruding move's E is scaled) is played on past that
    stretch's stop until the states agree (here: the end of the file), and still gives the
    full pass's figures."""
    profile = load_profile("prusa-mk3s")
    src = SAMPLES + "prusa_gyroid.gcode"
    with open(src, newline="") as fh:
        lines = fh.readlines()
    k = next(i for i in range(len(lines) // 2, len(lines)) if lines[i].startswith("G1 X") and " E" in lines[i])
    res1, led = fsim.simulate_ledger(src, profile, [(k, k)])
    lines[k] = lines[k] + "M221 S90\n"     # a flow factor (the file has 95) that stays after the stretch
    dst = tmp_path / "f.gcode"
    dst.write_text("".join(lines))
    lo, hi = led.lo[0], led.hi[0]
    got, played = fsim.replay_runs(str(dst), profile, led, [(lo, hi, led.line[lo] + 1, led.line[hi] + 1)])
    assert played[0][1] > hi            # played on past the stop after the change
    _same_result(got, fsim.simulate_file(str(dst), profile))


def _check_remeasure(monkeypatch, path, prof):
    """Run process; in its second pass, compare the partial re-measure with a full
    measure of the same written file."""
    seen = []
    real = pipeline.remeasure

    def both(path_, profile, strokes, order, led, lines1, lines2, changed, or1, fig1, or2, opts):
        got = real(path_, profile, strokes, order, led, lines1, lines2, changed, or1, fig1, or2, opts)
        full = pipeline.measure(path_, profile, or2, opts)
        assert got is not None
        _same_result(got[0], full[0])
        for x, y in zip(got[1:4], full[1:4]):
            assert np.array_equal(x, y)          # per stroke: the same additions, bit for bit
        seen.append((int(changed.sum()), len(changed)))
        return got
    monkeypatch.setattr(pipeline, "remeasure", both)
    s = process(path, path + ".P.out", load_profile(prof), Options())
    os.unlink(path + ".P.out")
    return s, seen


SECOND_PASS = [("prusa_absolute_e.gcode", "prusa-mk3s"),         # absolute E, lines: 0.5 s
               pytest.param("prusa_gyroid.gcode", "prusa-mk3s", marks=pytest.mark.slow),
               pytest.param("prusa_gyroid_arcs.gcode", "prusa-mk3s", marks=pytest.mark.slow)]  # arcs, curves


@pytest.mark.parametrize("name,prof", SECOND_PASS)
def test_second_pass_measures_only_what_changed(monkeypatch, tmp_path, name, prof):
    """These files re-plan (2 passes): the second measure, spliced from the first pass's
    ledger, equals a full firmware-model pass on the written file."""
    # segments.JERK_CORNERS (session 29) keeps classic-jerk corners, and this sample (prusa-mk3s)
    # no longer overruns its budget: one pass.  Off, the segments are those this test was made on
    # (two passes under prusa-mk3s; other profiles are not touched by it)
    from gcode_opt import segments as _segments
    monkeypatch.setattr(_segments, "JERK_CORNERS", False)
    src = tmp_path / "g.gcode"
    src.write_bytes(open(SAMPLES + name, "rb").read())
    s, seen = _check_remeasure(monkeypatch, str(src), prof)
    assert s["rewrite_passes"] == 2 and len(seen) == 1
    changed, total = seen[0]
    assert 0 < changed < total


@pytest.mark.slow
@pytest.mark.parametrize("name", ["plate_gyroid.gcode", "plate_rectilinear.gcode"])
def test_second_pass_measure_on_the_plates(monkeypatch, tmp_path, name):
    path = os.path.join(CORPUS, name)
    if not os.path.exists(path):
        pytest.skip("make it with sample_gcode/make_corpus.sh")
    src = tmp_path / name
    os.symlink(path, src)
    s, seen = _check_remeasure(monkeypatch, str(src), "prusa-mk3s")
    assert len(seen) == s["rewrite_passes"] - 1


CONSTANT = {"profile", "path", "flavour", "_one_accel", "warnings"}     # set once, never by a line
NOTES = {"feature_seen"}          # what the reader noted for its caller: no later line reads it


@pytest.mark.parametrize("name", ["edge/m204_variants.gcode", "edge/relative_g91.gcode", "edge/g92_resets.gcode",
                                  "edge/inches_g20.gcode", "edge/klipper_macros.gcode",
                                  "edge/firmware_retraction.gcode", "prusa_gyroid_arcs.gcode"])
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24", "ender3"])
def test_reader_snapshot_restores_everything_a_line_changes(name, prof):
    """A reader restored from a snapshot taken half-way reads the rest of the file exactly
    as the reader that went on: same events, same state at the end.  And the snapshot
    names every attribute the reader has besides the ones fixed at construction."""
    profile = load_profile(prof)
    with open(SAMPLES + name, newline="") as fh:
        lines = fh.readlines()

    def ev_tuple(ev):
        if ev is None:
            return None
        return tuple(getattr(ev, a) if a not in ("lim", "arc") else
                     (None if getattr(ev, a) is None else tuple(getattr(getattr(ev, a), s)
                                                                for s in type(getattr(ev, a)).__slots__))
                     for a in type(ev).__slots__)

    for cut in (len(lines) // 3, len(lines) // 2, 2 * len(lines) // 3):
        a = MachineState(profile, name)
        for idx in range(cut):
            a.step(idx, lines[idx])
        assert set(vars(a)) - CONSTANT - NOTES == set(MachineState.MODAL)
        b = MachineState(profile, name)
        b.restore(a.snapshot())
        for idx in range(cut, len(lines)):
            assert ev_tuple(a.step(idx, lines[idx])) == ev_tuple(b.step(idx, lines[idx])), idx
        assert a.snapshot() == b.snapshot()


@pytest.mark.parametrize("name,prof", SECOND_PASS)
def test_second_pass_copies_unchanged_blocks_as_it_would_write_them(monkeypatch, tmp_path, name, prof):
    """The second rewrite copies the blocks whose segment plan the first wrote from the
    first's file: the output is byte for byte the one a full re-emission writes."""
    # segments.JERK_CORNERS (session 29) keeps classic-jerk corners, and this sample (prusa-mk3s)
    # no longer overruns its budget: one pass.  Off, the segments are those this test was made on
    # (two passes under prusa-mk3s; other profiles are not touched by it)
    from gcode_opt import segments as _segments
    monkeypatch.setattr(_segments, "JERK_CORNERS", False)
    profile = load_profile(prof)
    src = SAMPLES + name
    calls = {"hit": 0}
    real = pipeline._Reuse.block

    def counted(self, i, seg, beta):
        got = real(self, i, seg, beta)
        calls["hit"] += got is not None
        return got
    monkeypatch.setattr(pipeline._Reuse, "block", counted)
    s1 = process(src, str(tmp_path / "reused.gcode"), profile, Options())
    assert s1["rewrite_passes"] == 2 and calls["hit"] > 20
    monkeypatch.setattr(pipeline._Reuse, "block", lambda self, i, seg, beta: None)
    s2 = process(src, str(tmp_path / "emitted.gcode"), profile, Options())
    assert s2["rewrite_passes"] == 2
    assert (tmp_path / "reused.gcode").read_bytes() == (tmp_path / "emitted.gcode").read_bytes()
    assert sorted(os.listdir(tmp_path)) == ["emitted.gcode", "reused.gcode"]     # no .pass2 left behind
