"""The summary's per-stroke rows held as columns (summary.StrokeRows, issue 8 s51): the
command line's --json streams them a chunk at a time and its --report looks them up by
line, where before build_summary made a list of ~3 dicts a row (the --json run's peak:
151 MB on the rectilinear plate, 84 MB without --json).  Checked against the code they
replaced, kept here verbatim (3356fa2's summary._rows, round_list and dump_json): the same rows (keys,
order, values, types: bit for bit), the same JSON bytes, the same report data."""
import io
import json
import math
import os
import random
import re
import struct

import numpy as np
import pytest

from gcode_opt import cli, pipeline
from gcode_opt import summary as sm
from gcode_opt.profile import load_profile
from gcode_opt.report.data import build_report
from gcode_opt.stroke_columns import StrokeColumns
from gcode_opt.strokes import Stroke

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")
_INF = math.inf


# ---------------------------------------------------------------- 3356fa2, verbatim
_TWO52 = float(1 << 52)
_FLOAT_ONLY = {float}


def ref_round_list(vals, nd):
    """[round(v, nd) for v in vals] (nd 0..15), the same objects' values, at a fraction of
    the cost for Python floats: round() is correctly rounded (the decimal D / 10^nd nearest
    v, ties to even, read back as the double nearest it).  D is rint(v * 10^nd) unless the
    product lies within 2 ulp of a tie (its rounding could have moved it across): there,
    and for any value not a float, not finite or with |v * 10^nd| >= 2^52, round() itself.
    D / 10^nd, both exact doubles, is one correctly rounded division: the nearest double."""
    n = len(vals)
    if n < 64:
        return [round(v, nd) for v in vals]
    scale = float(10 ** nd)
    x = np.array(vals, dtype=float)
    with np.errstate(all="ignore"):
        p = x * scale
        d = np.rint(p)
        out = (d / scale).tolist()
        ap = np.abs(p)
        frac = ap - np.floor(ap)
        slow = ~(ap < _TWO52) | (np.abs(frac - 0.5) <= 2.0 * np.spacing(ap))
    for j in np.flatnonzero(slow).tolist():
        out[j] = round(vals[j], nd)
    if set(map(type, vals)) != _FLOAT_ONLY:
        for j, v in enumerate(vals):
            if type(v) is not float:      # (an int, a numpy scalar: its own __round__)
                out[j] = round(v, nd)
    return out


def ref_rows(cols, rows, kinds, out_first, t0, i0, t_law, i_law, t1, a21, beta, per_stroke):
    """The per-stroke rows of the strokes `rows` (an intp array into cols, a StrokeColumns):
    each column made in one pass (the same round() of each value), then the rows zip them."""
    r4 = ref_round_list(cols.float_values("length_d", rows), 4)
    rv0 = ref_round_list(cols.float_values("v0", rows), 3)
    rv1 = ref_round_list(cols.float_values("v1", rows), 3)
    rvf = ref_round_list(cols.float_values("v_feed", rows), 3)
    n_moves = cols.n_moves[rows].tolist()
    lines = (cols.first_idx[rows] + 1).tolist()
    features, layers = cols.values("feature", rows), cols.values("layer", rows)
    per_stroke.extend([
        {"line": line, "lines": nm, "kind": kind, "out_line": of + 1,
         "feature": fe, "layer": la, "length_mm": ln,
         "v0_mm_s": a, "v1_mm_s": b, "feed_mm_s": f,
         "time_s": {"before": x0, "law": xl, "after": x1},
         "int_a2": {"before": y0, "law": yl, "after": y1},
         "beta_s2": be if -_INF < be < _INF else None}     # (math.isfinite: NaN and +-inf are None)
        for line, nm, kind, of, fe, la, ln, a, b, f, x0, xl, x1, y0, yl, y1, be
        in zip(lines, n_moves, kinds, out_first, features, layers, r4, rv0, rv1, rvf, t0, t_law, t1, i0, i_law, a21,
               beta)])


def ref_dump_json(summary: dict, fh) -> None:
    """Write `summary` as JSON: indented as json.dump(indent=1) writes it, except that a
    top-level list of rows (per_stroke) has one compact row a line.  json's indenting
    encoder is pure Python: the gyroid plate's 11 MB summary took 0.59 s CPU, written this
    way (the C encoder, row by row) 0.23 s.  json.load reads the same object back."""
    import json
    fh.write("{")
    sep = "\n "
    for k, v in summary.items():
        fh.write(sep + json.dumps(k) + ": ")
        if isinstance(v, list) and len(v) > 1 and all(isinstance(r, (dict, list)) for r in v):
            fh.write("[\n  " + ",\n  ".join(json.dumps(r) for r in v) + "\n ]")
        else:
            fh.write(json.dumps(v, indent=1).replace("\n", "\n "))
        sep = ",\n "
    fh.write("\n}" if summary else "}")


# ---------------------------------------------------------------- helpers
def _bits(x):
    """x with every float as its bytes and every value tagged by its type."""
    if isinstance(x, float):
        return (type(x).__name__, struct.pack("<d", x))
    if isinstance(x, dict):
        return ("d", [(k, _bits(v)) for k, v in x.items()])
    if isinstance(x, (list, tuple)):
        return (type(x).__name__, [_bits(v) for v in x])
    return (type(x).__name__, x)


def _ref_list(cols, idx, row_cols):
    rows = np.asarray(idx, np.intp)
    out = []
    ref_rows(cols, rows, cols.values("kind", rows), *map(sm._as_list, row_cols), out)
    return out


def _text(summary, dump):
    buf = io.StringIO()
    dump(summary, buf)
    return buf.getvalue()


@pytest.fixture
def seen(monkeypatch):
    """build_summary's rows' inputs, each call's (cols, idx, row_cols, the rows it made)."""
    calls = []
    real = sm._summary_rows

    def spy(wanted, cols, idx, row_cols):
        got = real(wanted, cols, idx, row_cols)
        calls.append((cols, idx, row_cols, got))
        return got
    monkeypatch.setattr(sm, "_summary_rows", spy)
    return calls


RUNS = (("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
        ("prusa_concentric_arcs.gcode", "voron24"), ("prusa_gyroid_arcs.gcode", "prusa-mk3s"),
        ("cura_box.gcode", "ender3"))


# ---------------------------------------------------------------- real runs
@pytest.mark.parametrize("name,prof", RUNS)
def test_table_rows_are_the_old_rows_bit_for_bit(name, prof, tmp_path, seen, monkeypatch):
    opts = pipeline.Options()
    opts.summary_rows = "table"
    s = pipeline.process(os.path.join(SAMPLES, name), str(tmp_path / "o.gcode"), load_profile(prof), opts)
    (cols, idx, row_cols, table), = seen
    assert isinstance(s["per_stroke"], sm.StrokeRows) and s["per_stroke"] is table
    want = _ref_list(cols, idx, row_cols)
    assert len(want) == len(table) == s["strokes"]["retimed"] > 100
    assert _bits(list(table)) == _bits(want)
    monkeypatch.setattr(sm.StrokeRows, "CHUNK", 7)          # chunk seams inside the rows
    assert _bits(list(table)) == _bits(want)
    assert table == want and want == table and not (table != want)
    for i in (0, 1, len(want) // 2, len(want) - 1, -1, -len(want)):
        assert _bits(table[i]) == _bits(want[i])
    assert _bits(table[3:40:5]) == _bits(want[3:40:5])
    # the JSON: the same bytes as the old writer wrote from the old rows
    assert _text(s, sm.dump_json) == _text({**s, "per_stroke": want}, ref_dump_json)
    # the API's default: the list, the same rows
    assert table == _ref_list(cols, idx, row_cols)


def _masked(text):
    text = re.sub(r'"timing_s": \{[^}]*\}', '"timing_s": X', text)
    return re.sub(r'"elapsed_s": [^,\n]*', '"elapsed_s": X', text)


@pytest.mark.parametrize("name,prof", RUNS[:3])
def test_command_line_json_is_the_old_bytes(name, prof, tmp_path, seen, monkeypatch):
    """--json: the file is what the old rows and writer wrote (the timing keys aside, which
    vary run to run), and what the API's list of rows writes."""
    monkeypatch.setattr(sm.StrokeRows, "CHUNK", 100)
    src = os.path.join(SAMPLES, name)
    out, js = tmp_path / "o.gcode", tmp_path / "s.json"
    assert cli.main(["process", src, "-o", str(out), "--profile", prof, "--json", str(js), "-q"]) == 0
    (cols, idx, row_cols, table), = seen
    assert isinstance(table, sm.StrokeRows)
    got = js.read_text()
    parsed = json.loads(got)
    # the old writer on the same summary (key order as written) with the old rows in place
    parsed["per_stroke"] = _ref_list(cols, idx, row_cols)
    assert got == _text(parsed, ref_dump_json)
    # the API (a list of rows), written by the old writer
    opts = pipeline.Options()
    s = pipeline.process(src, str(tmp_path / "api.gcode"), load_profile(prof), opts)
    s["output"] = str(out)
    assert isinstance(s["per_stroke"], list)
    assert _masked(got) == _masked(_text(s, ref_dump_json))


def test_report_data_from_the_table_is_the_lists(tmp_path, seen):
    """The report reads the summary's rows by line (row_at_line) where it had a dict of
    them: the same data, with the table and with the old list of rows."""
    src = os.path.join(SAMPLES, "prusa_gyroid_arcs.gcode")
    prof = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    opts.summary_rows = "table"
    out = str(tmp_path / "o.gcode")
    s = pipeline.process(src, out, prof, opts)
    (cols, idx, row_cols, table), = seen
    d_table, _ = build_report(src, out, prof, s, ringing=False)
    d_list, _ = build_report(src, out, prof, {**s, "per_stroke": _ref_list(cols, idx, row_cols)}, ringing=False)
    assert repr(d_table) == repr(d_list)
    assert any("law" in r["time_s"] for r in d_table["per_stroke"])


# ---------------------------------------------------------------- odd columns
# texts that hold the rows' separator or a quote (the JSON writer cuts chunks where a row starts)
NASTY = ('}, {"line": ', 'x}, {', '{"line": 3}', 'a"b\\', "\u00e9\n")


def _stroke(rng, line):
    s = Stroke.__new__(Stroke)
    if rng.random() < 0.8:
        s.kind = rng.choice(("line", "curve", "arc"))
    s.length_d, s.v0, s.v1, s.v_feed = (rng.uniform(0.1, 90.0) for _ in range(4))
    s.int_v2 = rng.uniform(0.0, 9.0)
    s.layer, s.feature = rng.choice((rng.randrange(5), None)), rng.choice(("sparse_infill", "perimeter", None) + NASTY)
    s.first_idx = line
    s.last_idx = line + rng.randrange(4)
    return s


def _odd_case(n, seed, ints=False):
    rng = random.Random(seed)
    lines = [rng.randrange(10 ** 5) for _ in range(n)]
    lines[n // 2:n // 2 + 2] = [lines[0], lines[0]]          # several strokes on one line
    ss = [_stroke(rng, ln) for ln in lines]
    if ints:                                                  # a value not a float: the column a list
        ss[1].v0, ss[2].length_d = 7, np.float64(2.34565)
    # (and values whose product by 10^nd rounds onto a tie: rint alone rounds them the wrong way)
    odd = [math.nan, math.inf, -math.inf, -0.0, 0.0, 5e-324, 1e308, 1.0594999999999999, 1.0635, 1.00025, 1.00045]
    for s in ss:
        if rng.random() < 0.2:
            setattr(s, rng.choice(("length_d", "v0", "v1", "v_feed")), rng.choice(odd))
    cols = StrokeColumns(ss)
    idx = np.array(rng.sample(range(n), n - 3), np.intp)
    m = len(idx)
    row_cols = [np.arange(m, dtype=np.int64) * 3] + [
        np.array([rng.choice(odd) if rng.random() < 0.05 else rng.uniform(-1, 1) * 10 ** rng.randrange(-8, 4)
                  for _ in range(m)]) for _ in range(7)]
    return cols, idx, row_cols


@pytest.mark.parametrize("n,seed,ints", [(5, 0, False), (70, 1, False), (300, 2, True), (2100, 3, False)])
def test_odd_columns_rows_and_json(n, seed, ints, monkeypatch):
    cols, idx, row_cols = _odd_case(n, seed, ints)
    if ints:
        assert isinstance(cols.floats["v0"], list) and isinstance(cols.floats["length_d"], list)
    for as_lists in (False, True):
        rc = [c.tolist() for c in row_cols] if as_lists else row_cols
        want = _ref_list(cols, idx, rc)
        for chunk in (1024, 64, 1):
            monkeypatch.setattr(sm.StrokeRows, "CHUNK", chunk)
            table = sm.StrokeRows(cols, idx, *rc)
            assert _bits(list(table)) == _bits(want)
            assert _text({"a": 1, "per_stroke": table, "z": [1]}, sm.dump_json) == \
                _text({"a": 1, "per_stroke": want, "z": [1]}, ref_dump_json)
    # the rounded fields: round() itself, value by value
    rows = np.asarray(idx, np.intp)
    for key, name, nd in (("length_mm", "length_d", 4), ("v0_mm_s", "v0", 3), ("v1_mm_s", "v1", 3),
                          ("feed_mm_s", "v_feed", 3)):
        assert _bits([r[key] for r in table]) == _bits([round(v, nd) for v in cols.float_values(name, rows)])
    # a short column: as many rows as the zip made
    k = len(idx) - 1
    short = [*row_cols[:3], row_cols[3][:k], *row_cols[4:]]
    table = sm.StrokeRows(cols, idx, *short)
    assert len(table) == k and _bits(list(table)) == _bits(_ref_list(cols, idx, short))


def test_row_at_line_is_the_dicts_lookup():
    cols, idx, row_cols = _odd_case(400, 5)
    table = sm.StrokeRows(cols, idx, *row_cols)
    want = _ref_list(cols, idx, row_cols)
    by_line = {p["line"]: p for p in want}
    assert len(by_line) < len(want)                          # (several rows on one line: the last one)
    # in line order (the report's), then backwards and in a jumble (row_at_line keeps a chunk of rows made)
    lines = sorted(by_line)
    for line in lines + [0, -1, 10 ** 6, min(by_line) - 1, max(by_line) + 1] + lines[::-1] + lines[::7] + lines[3::5]:
        got = table.row_at_line(line)
        assert (got is None) == (line not in by_line)
        if got is not None:
            assert _bits(got) == _bits(by_line[line])


@pytest.mark.parametrize("m", [0, 1, 2])
def test_short_tables_are_written_as_lists(m):
    cols, idx, row_cols = _odd_case(8, 9)
    table = sm.StrokeRows(cols, idx[:m], *(c[:m] for c in row_cols))
    want = _ref_list(cols, idx[:m], [c[:m] for c in row_cols])
    assert len(table) == m and table == want and _bits(list(table)) == _bits(want)
    assert _text({"per_stroke": table}, sm.dump_json) == _text({"per_stroke": want}, ref_dump_json)
    with pytest.raises(IndexError):
        table[m]
    assert not (table == tuple(want)) and table != [1] * (m + 1)
