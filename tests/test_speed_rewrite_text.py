"""The rewrite pass's fast paths (issue 8) against the code they replaced, kept below verbatim
as references (start commit fcf532c): emit.StrokeText and emit_stroke, the pipeline's
_stroke_text, _stroke_block and _validate, and validate.validate_block's line-by-line reading.

The written text must be the same bytes and the validator must reject exactly what it
rejected, with the same reason: compared on every block of real files (four flavours,
relative and absolute E, arcs), on mutations of those blocks, and on synthetic strokes
(points inside moves, comments, CRLF, lines without E or X, knots past the end, junction
commands)."""
from __future__ import annotations

import math
import random

import numpy as np
import pytest

from gcode_opt import emit, pipeline, validate
from gcode_opt import features as feat
from gcode_opt.emit import (BEGIN, END, _exact_text, _feed_text, _floats, _fmt_units, _num, _num1,
                            _start_decimals, _units, accel_command, emit_arc)
from gcode_opt.strokes import K_ARC
from gcode_opt.validate import (MAX_CMD_BYTES, E_TOL, BlockInvalid, Geometry, _check_m204, _check_m204_value,
                                _check_m205, _check_move, _check_plain_g1, _check_svl, _G1_PLAIN, _M204_PLAIN,
                                _ShortMoves)
from gcode_opt.words import decimals, param_texts, split_comment, strip_checksum


# ------------------------------------------------------------------ references (fcf532c)
class RefStrokeText:
    """What emission needs from the original lines of one stroke."""

    def __init__(self, raws, x_start_text, y_start_text, e_start_units):
        self.raws = raws
        self.x_start_text, self.y_start_text = x_start_text, y_start_text
        self.comments = []
        xs, ys, es, given = [], [], [], []
        xt, yt = x_start_text, y_start_text
        for raw in raws:
            body = raw.rstrip("\r\n")
            code, comment = split_comment(body)
            if code[:1] != "G" or "*" in code:     # else there is no N word or checksum to drop
                code, _ = strip_checksum(code)
            p = param_texts(code)
            xt = p.get("X", xt)
            yt = p.get("Y", yt)
            xs.append(xt)
            ys.append(yt)
            es.append(p.get("E", "0"))
            given.append("E" in p)
            self.comments.append(comment)
        self.x_texts, self.y_texts, self.e_texts = xs, ys, es
        self.e_given = given          # the line has an E word (the validator sums those)
        # the start point's precision counts too (a 4-decimal start, 3-decimal end: new
        # points rounded to 3 decimals would be up to 0.0015 mm off the segment)
        self.dec_xy = max([decimals(t) for t in xs + ys] + [_start_decimals(x_start_text),
                                                            _start_decimals(y_start_text), 3])
        self.dec_e = max([decimals(t) for t in es] + [5])
        self.e_start_units = e_start_units
        self.newline = raws[0][len(raws[0].rstrip("\r\n")):] or "\n"


def ref_closing(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl):
    """Lines that end every block: the original's acceleration, Klipper's cruise ratio
    and the modal F back in force, then the end marker."""
    out = [accel_command(flavour, accel_restore, extruding, round_up=False) + nl]
    if flavour == "klipper":
        out.append(f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO={_num(mcr_restore, 3)}{nl}")
    out.append(f"G1 F{_exact_text(feed_restore_v * 60.0)}{nl}")
    out.append(f"{END}{nl}")
    return out


def ref_emit_stroke(st: RefStrokeText, ends_d, s, v, accels, feeds, *, x0_text, y0_text, e_rel, flavour,
                accel_restore, mcr_restore, feed_restore_v, extruding=True, header="", first_cmds=None):
    """Text of the block replacing the stroke.  s, v: knots (mm, mm/s) including every
    original vertex (ends_d); accels (mm/s^2) and feeds (mm/s): one per segment.
    first_cmds: (before, after) lines around the first move (a junction command that
    slows the corner into the stroke, and the value in force back: corners.py)."""
    nl = st.newline
    dxy, de = st.dec_xy, st.dec_e
    # Python floats, not numpy scalars: the same IEEE numbers, a fraction of the per-use cost
    s, accels, feeds = _floats(s), _floats(accels), _floats(feeds)
    out = [f"{BEGIN}{header}{nl}"]
    if flavour == "klipper":
        out.append(f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0{nl}")
    # integer units of every original vertex
    xu = [_units(x0_text, dxy)] + [_units(t, dxy) for t in st.x_texts]
    yu = [_units(y0_text, dxy)] + [_units(t, dxy) for t in st.y_texts]
    if e_rel:
        e_move_u = [_units(t, de) for t in st.e_texts]
    else:
        ev = [st.e_start_units] + [_units(t, de) for t in st.e_texts]
        e_move_u = [ev[i + 1] - ev[i] for i in range(len(st.e_texts))]
    starts_d = [0.0] + list(ends_d[:-1])
    move = 0
    e_done_u = 0                         # units extruded so far inside the current move
    e_abs_u = st.e_start_units
    last_accel = None
    last_a = None
    k_total = len(s) - 1
    accel_word = accel_command(flavour, 1.0, extruding)[:-1]      # "M204 S" / "M204 P" / "M204 T"
    isfinite, ceil = math.isfinite, math.ceil
    tol_d = 1e-9 * max(1.0, ends_d[-1])
    for k in range(1, k_total + 1):
        # which original move does this segment end in?  (vertices are knots)
        if s[k] > ends_d[move] + tol_d:
            raise AssertionError("a knot skipped an original vertex")   # would lose its E
        d_move = ends_d[move] - starts_d[move]
        frac = 1.0 if d_move <= 0 else min(1.0, max(0.0, (s[k] - starts_d[move]) / d_move))
        at_vertex = abs(s[k] - ends_d[move]) <= tol_d
        if at_vertex:
            xt, yt = st.x_texts[move], st.y_texts[move]
            e_target_u = e_move_u[move]
            comment = st.comments[move]
        else:
            xt = _fmt_units(round(xu[move] + (xu[move + 1] - xu[move]) * frac), dxy)
            yt = _fmt_units(round(yu[move] + (yu[move + 1] - yu[move]) * frac), dxy)
            e_target_u = round(e_move_u[move] * frac)
            comment = ""
        de_u = e_target_u - e_done_u
        e_done_u = e_target_u
        e_abs_u += de_u
        a = accels[k - 1]
        if a != last_a:                  # the same value gives the same command
            if not (isfinite(a) and a > 0.0):
                accel_command(flavour, a, extruding)     # raises, saying why
            # accel_command(flavour, a, extruding) written out: once per segment
            cmd = accel_word + _num1(max(ceil(a * 10.0 - 1e-9) / 10.0, 0.1))
            last_a = a
            if cmd != last_accel:
                out.append(cmd + nl)
                last_accel = cmd
        f = feeds[k - 1]                 # _feed_text written out
        if not (isfinite(f) and f > 0.0):
            _feed_text(f)                # raises, saying why
        f = _num1(max(ceil(f * 600.0 - 1e-6) / 10.0, 0.1))
        if e_rel:
            e_txt = _fmt_units(de_u, de)
        elif at_vertex:
            e_txt = st.e_texts[move]
        else:
            e_txt = _fmt_units(e_abs_u, de)
        words = f"G1 X{xt} Y{yt}"
        if extruding:
            words += f" E{e_txt}"
        if k == 1 and first_cmds:
            out.append(first_cmds[0] + nl)
        out.append(f"{words} F{f}{(' ' + comment) if comment else ''}{nl}")
        if k == 1 and first_cmds:
            out.append(first_cmds[1] + nl)
        if at_vertex:
            e_done_u = 0
            if move < len(ends_d) - 1:
                move += 1
    out += ref_closing(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl)
    return "".join(out)


def ref_validate_block(text: str, flavour: str, accel_max_a: float, geometry: Geometry | None = None,
                   extruding: bool = True, kind: str | None = None, e_check=None,
                   min_move_d: float = 0.0) -> None:
    """Raise BlockInvalid (reason in its message) unless every line of the block is well
    formed for `flavour`, every value is finite and in range (F > 0, 0 < accel <=
    accel_max_a + the 0.1 of the emitter's rounding) and every point is on the path.

    e_check = (e_rel, e_value): the filament the block must lay, as the original did: with
    relative E the sum of its E words equals e_value (the original's sum), with absolute E
    its last E word equals e_value (the original's last).

    min_move_d: no move may travel less than this in both X and Y (Profile.min_move_d),
    unless the original has a move as short (geometry's polyline)."""
    lines = text.splitlines()
    if len(lines) < 2 or not lines[0].startswith(BEGIN + ": replaces ") or lines[-1] != END:
        raise BlockInvalid("validator: block not fenced")
    if kind is not None and f"kind={kind}" not in lines[0]:
        raise BlockInvalid("validator: header does not name the kind")
    limit = MAX_CMD_BYTES.get(flavour)
    e_words = []
    short = _ShortMoves(geometry, min_move_d) if min_move_d > 0 and geometry is not None else None
    for line in lines[1:-1]:
        # the emitter's own plain lines (no comment, no spaces around: the line is its own
        # code part) take the same checks without the general path's splitting
        m = _G1_PLAIN(line)
        if m is not None:
            if limit is not None and len(line.encode()) > limit:
                raise BlockInvalid("validator: line longer than the firmware's command buffer")
            e, x, y = _check_plain_g1(m, geometry)
            if e is not None:
                e_words.append(e)
            if short is not None:
                short.check(x, y)
            continue
        m = _M204_PLAIN(line)
        if m is not None:
            if limit is not None and len(line.encode()) > limit:
                raise BlockInvalid("validator: line longer than the firmware's command buffer")
            _check_m204_value(m.group(1), float(m.group(2)), flavour, accel_max_a, extruding)
            continue
        code = line.split(";", 1)[0].strip()
        if not code:
            raise BlockInvalid("validator: empty or comment line inside a block")
        if limit is not None and len(code.encode()) > limit:
            raise BlockInvalid("validator: line longer than the firmware's command buffer")
        toks = code.split()
        cmd = toks[0].upper()
        if cmd != toks[0]:
            raise BlockInvalid("validator: lower-case command")
        if cmd == "G1":
            m = _G1_PLAIN(code)
            e, x, y = _check_plain_g1(m, geometry) if m is not None else _check_move(cmd, toks[1:], geometry)
            if e is not None:
                e_words.append(e)
            if short is not None:
                short.check(x, y)
        elif cmd in ("G2", "G3"):
            e, x, y = _check_move(cmd, toks[1:], geometry)
            if e is not None:
                e_words.append(e)
            if short is not None:
                short.check(x, y)
        elif cmd == "M204":
            m = _M204_PLAIN(code)
            if m is not None:            # one word, its letter and number proven: the value checks
                _check_m204_value(m.group(1), float(m.group(2)), flavour, accel_max_a, extruding)
            else:
                _check_m204(toks[1:], flavour, accel_max_a, extruding)
        elif cmd == "SET_VELOCITY_LIMIT":
            _check_svl(toks[1:], flavour, accel_max_a)
        elif cmd == "M205":
            _check_m205(toks[1:], flavour)
        else:
            raise BlockInvalid(f"validator: command {cmd} not allowed in a block")
    if e_check is not None:
        e_rel, e_value = e_check
        got = math.fsum(e_words) if e_rel else (e_words[-1] if e_words else None)
        if got is None or abs(got - e_value) > E_TOL * (1.0 + abs(e_value)):
            raise BlockInvalid("validator: filament differs from the original's")


def ref_validate(text, s, raws, x0, y0, accel0, profile, parsed=None):
    """validate.py on one block; the path and the filament are the original's own (its raw
    X/Y/E words; `parsed`, the emitter's StrokeText of the same lines, saves reading them
    twice)."""
    pts = [(x0, y0)]
    e_words = []
    if parsed is not None:
        x_start, y_start = parsed.x_start_text, parsed.y_start_text
        for xt, yt, et, has_e in zip(parsed.x_texts, parsed.y_texts, parsed.e_texts, parsed.e_given):
            # a line without X keeps the text before it: the start's (x0 itself) or a word's
            pts.append((x0 if xt is x_start else float(xt), y0 if yt is y_start else float(yt)))
            if has_e:
                e_words.append(float(et))
    else:
        for raw in raws:
            p = param_texts(strip_checksum(split_comment(raw.rstrip("\r\n"))[0])[0])
            pts.append((float(p.get("X", pts[-1][0])), float(p.get("Y", pts[-1][1]))))
            if "E" in p:
                e_words.append(float(p["E"]))
    extruding = s.feature != feat.TRAVEL
    e_check = None
    if extruding and e_words:
        e_check = (True, math.fsum(e_words)) if s.e_rel else (False, e_words[-1])
    arc = None if s.kind != K_ARC else (s.arc.cx, s.arc.cy, s.arc.r, s.arc.theta0, s.arc.sweep)
    # a restore of the acceleration the slicer had in force is as acceptable as the original line
    accel_max_a = max(profile.max_accel_a, accel0) if math.isfinite(accel0) else profile.max_accel_a
    ref_validate_block(text, profile.flavour, accel_max_a, Geometry([pts[0], pts[-1]] if arc else pts, arc),
                   extruding=extruding, kind=s.kind, e_check=e_check,
                   min_move_d=getattr(profile, "min_move_d", 0.0))


def ref_stroke_block(s, raws, seg, beta, x0, y0, e0, accel0, mcr0, profile, parsed=None):
    """G-code text replacing one stroke, from its segment plan `seg`.  The header names
    the kind (line, curve, arc) after "replaces N lines" (verify.py and the report read it)."""
    dec = 8
    beta_txt = "inf" if not np.isfinite(beta) else f"{beta:.4g}"
    if s.kind == K_ARC:
        header = (f": replaces {len(raws)} lines, kind={s.kind}, {len(seg.s) - 1} sub-arcs, T={seg.time_t:.4f}s "
                  f"(was {s.time_t:.4f}s), beta={beta_txt}s^2")
        return emit_arc(raws[0], f"{x0:.{dec}f}", f"{y0:.{dec}f}", e0, s.arc, seg.s, seg.accel, seg.feed,
                        e_rel=s.e_rel, flavour=profile.flavour, accel_restore=accel0, mcr_restore=mcr0,
                        feed_restore_v=s.v_feed, header=header)
    st_text = parsed if parsed is not None else ref_stroke_text(raws, x0, y0)
    st_text.e_start_units = int(round(e0 * 10 ** st_text.dec_e))
    header = (f": replaces {len(raws)} lines, kind={s.kind}, {len(seg.s) - 1} segments, T={seg.time_t:.4f}s "
              f"(was {s.time_t:.4f}s), beta={beta_txt}s^2")
    return ref_emit_stroke(st_text, s.ends_d, seg.s, seg.v, seg.accel, seg.feed, x0_text=f"{x0:.{dec}f}",
                       y0_text=f"{y0:.{dec}f}", e_rel=s.e_rel, flavour=profile.flavour, accel_restore=accel0,
                       mcr_restore=mcr0, feed_restore_v=s.v_feed, extruding=s.feature != feat.TRAVEL,
                       header=header, first_cmds=getattr(seg, "first_cmds", None))


def ref_stroke_text(raws, x0, y0):
    """The emitter's reading of a stroke's original lines (StrokeText), start point
    written with 8 decimals as _stroke_block writes it."""
    return RefStrokeText(raws, f"{x0:.8f}", f"{y0:.8f}", 0)


# ------------------------------------------------------------------ real files
SAMPLES = "sample_gcode/"
CASES = [("prusa_gyroid.gcode", "prusa-mk3s"),           # marlin-legacy, curves, relative E
         ("prusa_absolute_e.gcode", "prusa-mk3s"),       # absolute E
         ("prusa_klipper.gcode", "voron24"),             # klipper: cruise-ratio lines
         ("cura_box.gcode", "ender3"),                   # marlin2 (M204 P), Cura's lines
         ("prusa_gyroid_arcs.gcode", "generic-marlin")]  # G2/G3 arcs (2.5 s of planning)
SLOW = ("prusa_gyroid_arcs.gcode", "cura_box.gcode")        # the synthetic tests cover M204 P and arcs too
NAMES = [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n, _ in CASES]


def _planned(name, prof_name):
    from gcode_opt.profile import load_profile
    from gcode_opt.schedule import plan_inputs, plan_strokes
    prof = load_profile(prof_name)
    opts = pipeline.Options()
    strokes, sim0 = pipeline.analyse(SAMPLES + name, prof, opts)
    pin = plan_inputs(strokes, prof, opts)
    plan = plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
    return prof, opts, strokes, plan


def _rewrite(path, strokes, plan, prof, opts, tmp_path, tag):
    import copy
    plan = copy.deepcopy(plan)
    out = tmp_path / f"{tag}.gcode"
    with open(out, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        ranges = pipeline.rewrite(path, fh, strokes, plan, prof, opts, {})
    return out.read_bytes(), list(plan.reason), plan.retime.tolist(), ranges


_RUNS = {}


def _real_run(name, tmp_path_factory):
    """The new rewrite of a case (recording every validate_block call) and the reference's
    (its _stroke_text, _stroke_block and _validate), on the same plan; made once."""
    if name in _RUNS:
        return _RUNS[name]
    prof_name = dict(CASES)[name]
    tmp = tmp_path_factory.mktemp(name.split(".")[0])
    prof, opts, strokes, plan = _planned(name, prof_name)
    calls = []
    real_vb = pipeline.validate_block

    def recording(text, flavour, accel_max_a, geometry=None, **kw):
        calls.append((text, flavour, accel_max_a, None if geometry is None else
                      (list(geometry.pts) if geometry.pts is not None else None, geometry.arc), kw))
        return real_vb(text, flavour, accel_max_a, geometry, **kw)
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(pipeline, "validate_block", recording)
        new = _rewrite(SAMPLES + name, strokes, plan, prof, opts, tmp, "new")
        mp.undo()
        mp.setattr(pipeline, "_stroke_text", ref_stroke_text)
        mp.setattr(pipeline, "_stroke_block", ref_stroke_block)
        mp.setattr(pipeline, "_validate", ref_validate)
        ref = _rewrite(SAMPLES + name, strokes, plan, prof, opts, tmp, "ref")
    finally:
        mp.undo()
    _RUNS[name] = (new, ref, calls, strokes)
    return _RUNS[name]


@pytest.mark.parametrize("name", NAMES)
def test_rewrite_is_the_reference_bytes(tmp_path_factory, name):
    (text, reasons, retime, ranges), (text_r, reasons_r, retime_r, ranges_r), calls, strokes = \
        _real_run(name, tmp_path_factory)
    assert sum(retime) > 0 and len(calls) >= sum(retime)
    assert text == text_r
    assert reasons == reasons_r and retime == retime_r and ranges == ranges_r


def test_real_files_take_the_fast_paths(tmp_path_factory):
    """The fast paths are what runs on real strokes (else this file tests nothing new):
    plain lines are read by the one-regex reading, and the validator's column pass
    accepts the blocks the emitter writes."""
    n_calls = n_fast = 0
    for name in ("prusa_gyroid.gcode", "prusa_absolute_e.gcode", "prusa_klipper.gcode"):
        _, _, calls, strokes = _real_run(name, tmp_path_factory)
        for text, flavour, accel_max_a, geo, kw in calls:
            g = None if geo is None else Geometry(geo[0], geo[1])
            n_fast += validate._fast_ok(text, flavour, accel_max_a, g, kw.get("extruding", True),
                                        kw.get("kind"), kw.get("e_check"), kw.get("min_move_d", 0.0))
            n_calls += 1
    assert n_fast >= 0.95 * n_calls
    lines = open(SAMPLES + "prusa_gyroid.gcode", newline="").readlines()
    strokes = _real_run("prusa_gyroid.gcode", tmp_path_factory)[3]
    n_plain = sum(emit._plain_moves(lines[s.first_idx:s.first_idx + s.n_moves]) is not None for s in strokes[:300])
    assert n_plain >= 250


def _verdict(fn, *args, **kw):
    try:
        fn(*args, **kw)
    except Exception as e:      # noqa: BLE001 -- the verdict is the exception's kind and text
        return type(e).__name__, str(e)
    return None


def _both(text, flavour, accel_max_a, geo, kw):
    """(new verdict, reference verdict) on fresh geometries (they keep a search position)."""
    g_new = None if geo is None else Geometry(geo[0], geo[1])
    g_ref = None if geo is None else Geometry(geo[0], geo[1])
    return (_verdict(validate.validate_block, text, flavour, accel_max_a, g_new, **kw),
            _verdict(ref_validate_block, text, flavour, accel_max_a, g_ref, **kw))


NOISE = "0123456789.-+ eEXYZFSPTMG;\t\r\n\x0b\x85\u2028é*N"


def _mutate(text, rng):
    lines = text.split("\n")
    body = list(range(1, len(lines) - 2))           # between the header and END
    how = rng.randrange(14)
    if how == 0:                                     # one character changed / deleted / inserted
        i = rng.randrange(len(text))
        return text[:i] + rng.choice(NOISE) + text[i + 1:]
    if how == 1:
        i = rng.randrange(len(text))
        return text[:i] + text[i + 1:]
    if how == 2:
        i = rng.randrange(len(text))
        return text[:i] + rng.choice(NOISE) + text[i:]
    if not body:
        return text + "G1 X0 Y0\n"
    k = rng.choice(body)
    line = lines[k]
    if how == 3:                                     # a line twice, dropped, swapped
        lines.insert(k, line)
    elif how == 4:
        del lines[k]
    elif how == 5:
        j = rng.choice(body)
        lines[k], lines[j] = lines[j], lines[k]
    elif how == 6:                                   # a comment, blanks, CRLF
        lines[k] = line + rng.choice([" ; c", ";", " ", "\t", "\r"])
    elif how == 7:
        lines[k] = rng.choice([" ", "", "g1"]) + line[rng.choice([0, 2]):]
    elif how in (8, 9, 10):                          # a number replaced
        toks = line.split(" ")
        if len(toks) > 1:
            t = rng.randrange(1, len(toks))
            w = toks[t]
            num = w[1:] if w[:1].isalpha() else w.partition("=")[2]
            pre = w[:len(w) - len(num)]
            try:
                v = float(num)
            except ValueError:
                v = 1.0
            new = rng.choice([f"{v + rng.choice([1e-4, 5e-4, 8e-4, 2e-3, -7e-4, 0.05]):.4f}", f"{v:.9f}",
                              f"{-v}", "0", "-0", "1e3", "inf", "nan", f"{v * 10:.3f}", "1" * 320,
                              f"{v}.5", "+" + num, "." if not num else num + "0", f"{v:.8f}", ""])
            toks[t] = pre + new
            lines[k] = " ".join(toks)
    elif how == 11:                                  # a letter changed
        lines[k] = line.replace(rng.choice("XYEFS"), rng.choice("XYEFSPTIJZ"), 1)
    elif how == 12:                                  # the header or the end line
        j = rng.choice([0, len(lines) - 2])
        lines[j] = lines[j][:rng.randrange(len(lines[j]) + 1)]
    else:                                            # a long line
        lines[k] = line + " " + "F1" * rng.randrange(1, 60)
    return "\n".join(lines)


@pytest.mark.parametrize("name", NAMES)
def test_validator_verdicts_on_real_blocks(tmp_path_factory, name):
    """Every real block: the same verdict (all pass); 600 mutations of them: the same
    verdict and reason, both passes and rejections among them."""
    _, _, calls, _ = _real_run(name, tmp_path_factory)
    for text, flavour, accel_max_a, geo, kw in calls:
        new, ref = _both(text, flavour, accel_max_a, geo, kw)
        assert new == ref, text
    rng = random.Random(hash(name) & 0xffff)
    outcomes = set()
    for _ in range(600):
        text, flavour, accel_max_a, geo, kw = rng.choice(calls)
        bad = _mutate(text, rng)
        new, ref = _both(bad, flavour, accel_max_a, geo, kw)
        assert new == ref, bad
        outcomes.add(ref is None)
    assert outcomes == {True, False}


@pytest.mark.parametrize("name", NAMES)
def test_validator_verdicts_with_other_arguments(tmp_path_factory, name):
    """The same blocks under another flavour, a lower accel limit, the other E rule, a
    travel move, a wrong kind, a tighter min_move_d: the same verdicts."""
    _, _, calls, _ = _real_run(name, tmp_path_factory)
    rng = random.Random(7)
    for text, flavour, accel_max_a, geo, kw in rng.sample(calls, min(len(calls), 300)):
        kw2 = dict(kw)
        what = rng.randrange(6)
        if what == 0:
            flavour = rng.choice(["klipper", "marlin2", "marlin-legacy", "rrf"])
        elif what == 1:                  # about the block's largest M204 (the + 0.1 + 1e-9 margin)
            hi = max([float(ln[6:]) for ln in text.split("\n") if ln.startswith("M204 ")] or [1000.0])
            accel_max_a = rng.choice([100.0, accel_max_a * 0.5, hi - 0.1 - 2e-9, hi - 0.1 + 2e-9, hi - 0.15,
                                      hi - 0.1 - 1e-9, hi])
        elif what == 2 and kw2.get("e_check"):
            e_rel, v = kw2["e_check"]
            kw2["e_check"] = rng.choice([(not e_rel, v), (e_rel, v + 1e-3), (e_rel, v * (1 + 1e-8))])
        elif what == 3:
            kw2["extruding"] = not kw2.get("extruding", True)
        elif what == 4:
            kw2["kind"] = rng.choice(["line", "curve", "arc", "chain"])
        else:
            kw2["min_move_d"] = rng.choice([0.0, 0.5, 2.0, 5.0])
        if rng.random() < 0.1:
            geo = None
        new, ref = _both(text, flavour, accel_max_a, geo, kw2)
        assert new == ref, (text, flavour, accel_max_a, kw2)


@pytest.mark.parametrize("name", NAMES)
def test_validator_verdicts_on_every_number(tmp_path_factory, name):
    """Each number of sampled real blocks replaced in turn by a value at an edge of a rule
    (overflowing to inf, 0, -0, nine decimals, eight, a hair off the path): the same verdicts."""
    _, _, calls, _ = _real_run(name, tmp_path_factory)
    rng = random.Random(3)
    edges = ["1" * 320, "-" + "1" * 320, "1" * 90, "0", "-0", "1", "0.99999999", "0.000000001", "0.00000001",
             "-.5", "5.", None]
    for text, flavour, accel_max_a, geo, kw in rng.sample(calls, min(len(calls), 4)):
        # also without a command-buffer limit (a 320-digit number is then not too long but
        # infinite) and without a path (only the finiteness rules then)
        if rng.random() < 0.5:
            flavour = "klipper" if "\nM204 S" in text else "rrf"
        if rng.random() < 0.3:
            geo = None
        lines = text.split("\n")
        for k in range(1, len(lines) - 2):
            toks = lines[k].split(" ")
            for t in range(1, len(toks)):
                w = toks[t]
                num = w.partition("=")[2] if "=" in w else w[1:]
                for edge in edges:
                    if edge is None:     # a hair: the last digit +- 1, or 0.0007 more
                        edge = f"{float(num) + rng.choice([7e-4, -7e-4, 1e-3, 4e-4]):.4f}"
                    bad = lines[:k] + [" ".join(toks[:t] + [w[:len(w) - len(num)] + edge] + toks[t + 1:])] + lines[k + 1:]
                    new, ref = _both("\n".join(bad), flavour, accel_max_a, geo, kw)
                    assert new == ref, bad[k]


# ------------------------------------------------------------------ synthetic strokes
def _text_of(rng, v, dec):
    """A slicer-like text of v: fixed decimals, trailing zeros cut, or a bare '.5'."""
    t = f"{v:.{dec}f}"
    style = rng.randrange(4)
    if style == 0 and "." in t:
        t = t.rstrip("0").rstrip(".") or "0"
    elif style == 1 and t.startswith(("0.", "-0.")):
        t = t.replace("0.", ".", 1)
    return "0" if t in ("-0", "-") else t


def _raw_lines(rng, n, x0, y0, e0, e_rel, odd=True):
    """n original lines of a stroke (mostly plain "G1 X Y E"; with odd, the shapes the
    general reading takes: comments, CRLF, blanks, no E, no X, F, N/checksum, G01, '+')."""
    dec_xy = rng.choice([2, 3, 3, 4])
    dec_e = rng.choice([4, 5, 5, 6])
    x, y, e = x0, y0, e0
    raws, pts = [], []
    nl = "\r\n" if odd and rng.random() < 0.1 else "\n"
    for _ in range(n):
        ang = rng.uniform(0, 2 * math.pi)
        step = rng.choice([rng.uniform(0.05, 0.4), rng.uniform(0.5, 8.0)])
        x, y = round(x + step * math.cos(ang), dec_xy), round(y + step * math.sin(ang), dec_xy)
        de = round(step * 0.03, dec_e)
        e = de if e_rel else round(e + de, dec_e)
        xt, yt, et = _text_of(rng, x, dec_xy), _text_of(rng, y, dec_xy), _text_of(rng, e, dec_e)
        words = [f"X{xt}", f"Y{yt}", f"E{et}"]
        tail = ""
        if odd:
            r = rng.random()
            if r < 0.05:
                words.pop(2)                             # no E
            elif r < 0.08:
                words.pop(0)                             # no X (keeps the one before)
            elif r < 0.11:
                words.append("F1200")
            elif r < 0.14:
                words[0] = "X+" + xt.lstrip("-") if not xt.startswith("-") else words[0]
            r = rng.random()
            if r < 0.06:
                tail = rng.choice([" ; perimeter", ";c", "\t; x", " "])
        cmd = "G1"
        if odd and rng.random() < 0.03:
            cmd = "G01"
        line = f"{cmd} {' '.join(words)}{tail}"
        if odd and rng.random() < 0.03:
            line = f"N{len(raws) + 10} {line}*{rng.randrange(100)}"
        raws.append(line + nl)
        pts.append((float(xt) if "X" in line else pts[-1][0] if pts else x0, y))
    return raws, dec_xy


def _st_fields(st):
    return (st.x_texts, st.y_texts, st.e_texts, st.e_given, st.comments, st.dec_xy, st.dec_e, st.newline,
            st.e_start_units)


def test_stroke_text_is_the_reference():
    rng = random.Random(11)
    n_plain = 0
    for _ in range(1500):
        raws, _ = _raw_lines(rng, rng.randint(1, 12), rng.uniform(-5, 200), rng.uniform(-5, 200), 0.0,
                             rng.random() < 0.7, odd=rng.random() < 0.5)
        if rng.random() < 0.05:                          # a line the tokenizer refuses
            k = rng.randrange(len(raws))
            raws[k] = raws[k].replace("Y", rng.choice(["Y1.2.", "Y-", "Y1e1", "Y.", "Y--"]), 1)
        x0t, y0t = f"{rng.uniform(-5, 200):.8f}", f"{rng.uniform(-5, 200):.8f}"
        if rng.random() < 0.05:
            x0t = rng.choice(["nan", "inf", "12.34500000"])
        got, want = _verdict(emit.StrokeText, raws, x0t, y0t, 7), _verdict(RefStrokeText, raws, x0t, y0t, 7)
        assert got == want, raws
        if got is None:
            new, ref = emit.StrokeText(raws, x0t, y0t, 7), RefStrokeText(raws, x0t, y0t, 7)
            assert _st_fields(new) == _st_fields(ref), raws
            n_plain += new.values is not None
            if new.values is not None:                   # the validator's path: the texts' values
                xs, ys, es = new.values
                assert xs == [float(t) for t in ref.x_texts] and ys == [float(t) for t in ref.y_texts]
                assert es == [float(t) for t, g in zip(ref.e_texts, ref.e_given) if g]
    assert 500 < n_plain < 1450


@pytest.mark.parametrize("raws", [["G1 X1 Y1 E1\nG1 X2 Y2 E2\n", "\n"], ["G1 X1 Y1 E1\n\n", "G1 X2 Y2 E2"],
                                  ["G1 X1 Y1 E1\r", "G1 X2 Y2 E2\r"], ["G1 X1 Y1 E1\r\r\n"],
                                  ["G1 X1 Y1 E1 ;a\rb\n"], ["\ufeffG1 X1 Y1 E1\n"], ["G1 X1 Y1 E1\x85\n"]])
def test_stroke_text_of_odd_line_lists(raws):
    """Lists no file gives (lines holding or lacking line ends): the reference's reading."""
    got, want = _verdict(emit.StrokeText, raws, "0", "0", 0), _verdict(RefStrokeText, raws, "0", "0", 0)
    assert got == want
    if got is None:
        assert _st_fields(emit.StrokeText(raws, "0", "0", 0)) == _st_fields(RefStrokeText(raws, "0", "0", 0))


def _synthetic_stroke(rng):
    """(raws, x0, y0, e0, e_rel, ends_d, s, accels, feeds) with knots at every vertex and
    some inside moves; now and then a plan the emitter must refuse or handle oddly."""
    e_rel = rng.random() < 0.6
    x0, y0 = round(rng.uniform(10, 200), 3), round(rng.uniform(10, 200), 3)
    e0 = round(rng.uniform(0, 50), 5) if not e_rel else 0.0
    raws, _ = _raw_lines(rng, rng.randint(1, 10), x0, y0, e0, e_rel, odd=rng.random() < 0.3)
    st = RefStrokeText(raws, f"{x0:.8f}", f"{y0:.8f}", 0)
    px = [x0] + [float(t) for t in st.x_texts]
    py = [y0] + [float(t) for t in st.y_texts]
    ends = np.cumsum(np.hypot(np.diff(px), np.diff(py)))
    knots = [0.0]
    for k, end in enumerate(ends):
        start = 0.0 if k == 0 else ends[k - 1]
        for _ in range(rng.choice([0, 0, 0, 1, 2, 3])):
            knots.append(start + (end - start) * rng.random())
        knots.append(float(end))
    knots = sorted(knots)
    r = rng.random()
    if r < 0.03:
        knots.append(knots[-1])                          # a knot past the end (the last move again)
        knots.append(knots[-1] * (1 - 1e-3))
    elif r < 0.05 and len(knots) > 3:
        del knots[rng.randrange(1, len(knots) - 1)]      # may skip a vertex
    n_seg = len(knots) - 1
    base_a = rng.choice([500.0, 1234.56, 3000.0])
    accels = [rng.choice([base_a, base_a, rng.uniform(10, 5000), 0.04, 1e16, rng.uniform(1e13, 1e18)])
              for _ in range(n_seg)]
    feeds = [rng.choice([rng.uniform(0.001, 300.0), 50.0, 1e-9, 1e15, rng.uniform(1e11, 1e16)]) for _ in range(n_seg)]
    if rng.random() < 0.03:
        (accels if rng.random() < 0.5 else feeds)[rng.randrange(n_seg)] = rng.choice([0.0, -1.0, math.nan, math.inf])
    if rng.random() < 0.02:
        accels = accels[:-1]                             # one short: IndexError
    return raws, x0, y0, e0, e_rel, ends, np.array(knots), np.array(accels), np.array(feeds)


def test_emit_stroke_is_the_reference():
    rng = random.Random(5)
    n_inside = 0
    for _ in range(1200):
        raws, x0, y0, e0, e_rel, ends, s, accels, feeds = _synthetic_stroke(rng)
        flavour = rng.choice(["klipper", "marlin2", "marlin-legacy", "rrf"])
        kw = dict(x0_text=f"{x0:.8f}", y0_text=f"{y0:.8f}", e_rel=e_rel, flavour=flavour,
                  accel_restore=rng.choice([1000.0, 1234.5678, 0.25]), mcr_restore=rng.choice([0.0, 0.5, -0.0]),
                  feed_restore_v=rng.choice([30.0, 0.1884 / 60.0, 250.0]), extruding=rng.random() < 0.9,
                  header=": replaces x", first_cmds=rng.choice([None, None, ("M205 X5 Y5", "M205 X8 Y8")]))
        got = []
        for cls, fn in ((emit.StrokeText, emit.emit_stroke), (RefStrokeText, ref_emit_stroke)):
            st = cls(raws, f"{x0:.8f}", f"{y0:.8f}", 0)
            st.e_start_units = int(round(e0 * 10 ** st.dec_e))
            try:
                got.append(fn(st, ends, s, None, accels, feeds, **kw))
            except Exception as e:      # noqa: BLE001 -- the same refusal, for the same reason
                got.append((type(e).__name__, str(e)))
        assert got[0] == got[1], (raws, kw, s, accels, feeds)
        n_inside += isinstance(got[0], str) and got[0].count(" X") > len(raws)
    assert n_inside > 250


def test_validator_on_synthetic_blocks():
    """Blocks with comments, CRLF, junction commands, non-extruding moves, absolute E and
    points inside moves, each also mutated: the same verdicts as the reference."""
    rng = random.Random(9)
    outcomes = set()
    for _ in range(700):
        raws, x0, y0, e0, e_rel, ends, s, accels, feeds = _synthetic_stroke(rng)
        flavour = rng.choice(["klipper", "marlin2", "marlin-legacy", "rrf"])
        st = RefStrokeText(raws, f"{x0:.8f}", f"{y0:.8f}", 0)
        st.e_start_units = int(round(e0 * 10 ** st.dec_e))
        extruding = rng.random() < 0.9
        try:
            text = ref_emit_stroke(st, ends, s, None, accels, feeds, x0_text=f"{x0:.8f}", y0_text=f"{y0:.8f}",
                                   e_rel=e_rel, flavour=flavour, accel_restore=1000.0, mcr_restore=0.0,
                                   feed_restore_v=30.0, extruding=extruding,
                                   header=": replaces 3 lines, kind=line, 4 segments",
                                   first_cmds=rng.choice([None, ("M205 X5 Y5", "M205 X8 Y8"),
                                                          ("SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=2.000",
                                                           "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=5")]))
        except Exception:       # noqa: BLE001 -- a plan the emitter refuses: no block to check
            continue
        pts = [(x0, y0)] + [(float(x), float(y)) for x, y in zip(st.x_texts, st.y_texts)]
        e_words = [float(t) for t, g in zip(st.e_texts, st.e_given) if g]
        e_check = None if not e_words else ((True, math.fsum(e_words)) if e_rel else (False, e_words[-1]))
        kw = dict(extruding=extruding, kind=rng.choice(["line", None]), e_check=e_check,
                  min_move_d=rng.choice([0.0, 0.07, 0.3]))
        for block in (text, _mutate(text, rng), _mutate(_mutate(text, rng), rng)):
            new, ref = _both(block, flavour, rng.choice([3000.0, 1500.0]), (pts, None), kw)
            assert new == ref, block
            outcomes.add(ref is None)
    assert outcomes == {True, False}


class _Arc:
    def __init__(self, cx, cy, r, theta0, sweep):
        self.cx, self.cy, self.r, self.theta0, self.sweep = cx, cy, r, theta0, sweep


def test_validator_on_arc_blocks():
    """Arc blocks (emit_arc, unchanged) take the validator's arc branch: the same verdicts
    as the reference on them and on their mutations."""
    rng = random.Random(13)
    outcomes = set()
    for _ in range(300):
        cx, cy, r = rng.uniform(50, 150), rng.uniform(50, 150), rng.uniform(0.5, 30)
        th0, sweep = rng.uniform(-math.pi, math.pi), rng.choice([-1, 1]) * rng.uniform(0.2, 5.0)
        x0, y0 = round(cx + r * math.cos(th0), 3), round(cy + r * math.sin(th0), 3)
        x1, y1 = round(cx + r * math.cos(th0 + sweep), 3), round(cy + r * math.sin(th0 + sweep), 3)
        i, j = round(cx - x0, 3), round(cy - y0, 3)
        cx, cy = x0 + i, y0 + j
        r = math.hypot(x0 - cx, y0 - cy)
        arc = _Arc(cx, cy, r, math.atan2(y0 - cy, x0 - cx), sweep)
        length = r * abs(sweep)
        n = rng.randint(1, 6)
        s = np.array([0.0] + sorted(rng.uniform(0, length) for _ in range(n - 1)) + [length])
        e_rel = rng.random() < 0.7
        raw = f"{'G2' if sweep < 0 else 'G3'} X{x1} Y{y1} I{i} J{j} E{0.05 * length:.5f}\n"
        flavour = rng.choice(["klipper", "marlin2", "marlin-legacy", "rrf"])
        text = emit_arc(raw, f"{x0:.8f}", f"{y0:.8f}", 0.0, arc, s, [1500.0] * n, [40.0] * n, e_rel=e_rel,
                        flavour=flavour, accel_restore=1000.0, mcr_restore=0.0, feed_restore_v=30.0,
                        header=": replaces 1 lines, kind=arc, 3 sub-arcs")
        geo = ([(x0, y0), (x1, y1)], (arc.cx, arc.cy, arc.r, arc.theta0, arc.sweep))
        kw = dict(kind="arc", e_check=(True, float(f"{0.05 * length:.5f}")) if e_rel else None,
                  min_move_d=rng.choice([0.0, 0.07]))
        for block in (text, _mutate(text, rng)):
            new, ref = _both(block, flavour, 3000.0, geo, kw)
            assert new == ref, block
            outcomes.add(ref is None)
    assert outcomes == {True, False}


# ------------------------------------------------------------------ the text helpers
def test_canon_is_units_then_text():
    rng = random.Random(2)
    for _ in range(20000):
        whole = "".join(rng.choice("0123456789") for _ in range(rng.randint(0, 4)))
        frac = "".join(rng.choice("0123456789") for _ in range(rng.randint(0, 7)))
        if not (whole or frac):
            continue
        text = rng.choice(["", "-", "+"]) + whole + ("." + frac if frac or rng.random() < 0.3 else "")
        dec = max(decimals(text), rng.randint(1, 8))
        assert emit._canon(text) == _fmt_units(_units(text, dec), dec), text


def test_tenths_is_num1():
    rng = random.Random(4)
    ks = list(range(1, 3000)) + [rng.randrange(1, emit._TENTHS_MAX) for _ in range(20000)] + [emit._TENTHS_MAX - 1]
    for k in ks:
        assert emit._tenths(k) == _num1(max(k / 10.0, 0.1)), k


def test_decimals_at_least():
    rng = random.Random(6)
    for _ in range(5000):
        texts = [_text_of(rng, rng.uniform(-300, 300), rng.randint(0, 9)) for _ in range(rng.randint(0, 6))]
        least = rng.choice([3, 5])
        assert emit._decimals_at_least(texts, least) == max([decimals(t) for t in texts] + [least])


def test_closing_text_is_closing_joined():
    for args in [("klipper", 1000.0, True, 0.0, 30.0, "\n"), ("marlin2", 0.25, False, 0.5, 0.00314, "\r\n"),
                 ("klipper", 1000.0, True, -0.0, 30.0, "\n"), ("rrf", 1e5, True, 0.0, 1e-3, "\n")]:
        assert emit._closing_text(*args) == "".join(ref_closing(*args))
        assert emit._closing_text(*args) == "".join(ref_closing(*args))      # cached
    for bad in [("marlin2", math.nan, True, 0.0, 30.0, "\n"), ("marlin2", 1000.0, True, 0.0, 0.0, "\n")]:
        for _ in range(2):
            with pytest.raises(ValueError):
                emit._closing_text(*bad)


def test_fence_variants():
    """The block's fence and line ends, bent each way: the same verdicts as the reference."""
    pts = [(0.0, 0.0), (10.0, 0.0), (10.0, 5.0)]
    head = f"{BEGIN}: replaces 2 lines, kind=line, 3 segments"
    body = ["M204 S1000", "G1 X5 Y0 E0.2 F1200", "G1 X10 Y0 E0.2 F1200", "G1 X10 Y5 E0.2 F1200", "M204 S800",
            "G1 F3000"]
    good = "\n".join([head] + body + [END]) + "\n"
    variants = [good, good[:-1], good.replace("\n", "\r\n"), good.replace("\nG1 F3000\n", "\nG1 F3000"),
                good.replace(f"\n{END}", f"\n\n{END}"), good.replace(head, head + "\x0bx"),
                good.replace(head, head.replace("kind=line", "kind=curve")), good + END + "\n",
                good.replace(head + "\n", ""), head + "\n" + END + "\n", good.replace("\n", "\x85", 1),
                good.replace("G1 X5 Y0", "G1 X5 Y0\u2028G1 X5 Y0"), good.replace(BEGIN, BEGIN.upper()),
                f"{END}\n", "\n" + good, good.replace("\n", "\n ", 2)]
    for text in variants:
        for kind in ("line", None):
            new, ref = _both(text, "marlin-legacy", 3000.0, (pts, None),
                             dict(kind=kind, e_check=(True, 0.6), min_move_d=0.07))
            assert new == ref, repr(text)
    assert _both(good, "marlin-legacy", 3000.0, (pts, None), dict(kind="line"))[1] is None
