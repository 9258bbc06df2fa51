"""The JSON summary of one run: what was re-timed, and what it did, as the firmware model
executes the original and the re-timed file.  Keys are stable (README documents them)."""
from __future__ import annotations

import gc
import math
import os
from collections.abc import Sequence
from itertools import compress

import numpy as np

from . import objfields
from .distinct import value_codes
from .outranges import columns as range_columns
from .stroke_columns import StrokeColumns


FAULT_PREFIXES = ("error:", "validator:")    # plan.reason of a stroke isolated after a failure


def count_lines(path) -> int:
    """Lines of a file as iterating it in binary counts them (a last line without a
    newline counts), read in 1 MB chunks."""
    n, last = 0, b"\n"
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            n += chunk.count(b"\n")
            last = chunk[-1:]
    return n + (last != b"\n")


def _ratio(after, before):
    return None if not before else after / before - 1.0


# why moves outside every candidate stroke were left (coverage["left"]); the keys say it
NOT_CANDIDATE = "not a candidate: feature not selected, travel, shorter than --min-length or not re-timable"
DWELL = "dwell and waits (G4, M109/M190 heating, M400)"


def _share(part, whole):
    return None if not whole else part / whole


def coverage(strokes, pin, plan, sim0, sim1, idx, opts=None, reason_codes=None):
    """The whole-file headline (issue 9 item 5): what share of the original file's
    int|a|^2 dt and print time the re-timed strokes carried, what the whole file gained,
    and what was left as sliced, by reason -- each with its count and its share of the
    original's int|a|^2 dt and time (firmware model on the original).

    Candidates not re-timed are counted by plan.reason.  The moves outside every candidate
    stroke are what the original's totals leave after the candidates and the dwells: by
    feature when the analyse pass totalled the original by feature (opts.by_feature:
    feature -> [moves, time_t, int_a2] over every moving line), else as one bucket.

    strokes: StrokeColumns, or the list of strokes; reason_codes: _reason_codes(plan.reason)
    where the caller has them (build_summary)."""
    total_a2, total_t = float(sim0.int_a2), float(sim0.time_t)
    n = len(strokes)
    T0 = np.nan_to_num(np.asarray(pin.T_orig[:n], dtype=float), nan=0.0, posinf=0.0, neginf=0.0)
    I0 = np.nan_to_num(np.asarray(pin.I_orig[:n], dtype=float), nan=0.0, posinf=0.0, neginf=0.0)
    retimed = np.zeros(n, dtype=bool)
    retimed[np.asarray(idx, dtype=int)] = True
    left = {}

    def add(reason, count, unit, a2, t):
        g = left.setdefault(reason, {"count": 0, "unit": unit, "int_a2": 0.0, "time_s": 0.0})
        g["count"] += int(count)
        g["int_a2"] += float(a2)
        g["time_s"] += float(t)

    # each reason's strokes left as sliced: the re-timed ones coded past every reason
    if reason_codes is None:
        reason_codes = _reason_codes(plan.reason[:n])
    # (codes past n, if any, and their reasons' keys drop out: counted 0 below)
    code_of, code = reason_codes[0], reason_codes[1][:n].copy()
    code[retimed] = len(code_of)
    left_reasons = compress(code_of, (np.bincount(code, minlength=len(code_of) + 1)[:-1] > 0).tolist())
    for r in sorted(left_reasons):
        m = code == code_of[r]
        add(r or "not planned", m.sum(), "strokes", I0[m].sum(), T0[m].sum())
    dwell_t = float(getattr(sim0, "barrier_dwell_t", 0.0) or 0.0)
    by_feature = getattr(opts, "by_feature", None)
    if by_feature:
        selected = set(getattr(opts, "features", ()) or ())
        cols = StrokeColumns.of(strokes)
        feat_code_of, feat_code = cols.code_of["feature"], cols.codes["feature"]
        nm = cols.n_moves                                         # the candidates' moves
        for f, (moves, t, a2) in sorted(by_feature.items()):
            m = feat_code == feat_code_of.get(f, -1)              # candidates of this feature
            moves -= int(nm[m].sum())                             # (integers: the loop's sum)
            t, a2 = t - float(T0[m].sum()), a2 - float(I0[m].sum())
            if moves <= 0 and t <= 1e-9 * total_t:
                continue
            why = (f"feature not selected: {f}" if f not in selected else
                   f"{f}: selected, in no stroke (shorter than --min-length, sharp corners, not re-timable)")
            add(why, max(moves, 0), "moves", max(a2, 0.0), max(t, 0.0))
    else:
        rest_a2 = max(total_a2 - float(I0.sum()), 0.0)
        rest_t = max(total_t - float(T0.sum()) - dwell_t, 0.0)
        if rest_a2 > 0.0 or rest_t > 0.0:
            add(NOT_CANDIDATE, 0, "moves", rest_a2, rest_t)
    if dwell_t > 0.0:
        add(DWELL, 0, "", 0.0, dwell_t)
    for g in left.values():
        g["int_a2_share"] = _share(g["int_a2"], total_a2)
        g["time_share"] = _share(g["time_s"], total_t)
    left = dict(sorted(left.items(), key=lambda kv: (-(kv[1]["int_a2_share"] or 0.0), -(kv[1]["time_share"] or 0.0))))
    a2_in, t_in = float(I0[retimed].sum()), float(T0[retimed].sum())
    return {
        "int_a2_before": total_a2, "time_s_before": total_t,
        "retimed": {"strokes": int(retimed.sum()), "int_a2_share": _share(a2_in, total_a2),
                    "time_share": _share(t_in, total_t)},
        "whole_file": {"int_a2_change": _ratio(float(sim1.int_a2), total_a2),
                       "time_change": _ratio(float(sim1.time_t), total_t)},
        "left": left,
    }


def _reason_codes(reason):
    """value_codes of the reasons' texts (str of each): ({text: code} in the order of first
    appearance, each stroke's code), made once for coverage and the reasons' counts.  The
    reasons as they are where every one is a str (str() of a str is itself: a call of str
    a stroke, ~460 instructions, was ~24 M on the rectilinear plate)."""
    texts = reason.tolist() if isinstance(reason, np.ndarray) else list(reason)
    if set(map(type, texts)) != _STR_ONLY:
        texts = list(map(str, texts))
    return value_codes(texts)


_STR_ONLY = {str}


def _reason_counts(reason_codes):
    """Counter(texts) from _reason_codes' (the same keys in the same order, the same
    counts): a bincount of the codes, not a dict update a stroke."""
    code_of, code = reason_codes
    return dict(zip(code_of, np.bincount(code, minlength=len(code_of)).tolist()))


def ringing_section(before, after):
    """The "ringing" key from the ringing figures of the original and the written file
    (gcode_opt.ringing.figures / Collector.figures, the same model): model, before, after
    (per axis rms/peak and their ramp / corner / gentle-turn parts, the shaper's smoothing
    if one is set) and change (XY and per axis)."""
    from .ringing import summary_of
    return summary_of(before, after)


def build_summary(in_path, out_path, written_path, size_before, profile, opts, strokes, pin, plan, sim0, sim1,
                  out_ranges, t_after, a2_after, v2_after, elapsed_t, ringing=None):
    """strokes: the strokes' StrokeColumns (or the list of strokes, read into one).
    ringing: None, or (before, after) ringing figure dicts (the firmware-model passes over
    the original and the written file fed ringing.Collector): the summary's "ringing" key."""
    cols = StrokeColumns.of(strokes)
    out_first, _, idx = range_columns(out_ranges)
    T0 = pin.T_orig[idx] if len(idx) else np.zeros(0)
    I0 = pin.I_orig[idx] if len(idx) else np.zeros(0)
    V0 = cols.float_array("int_v2", idx)
    by_kind = {}
    row_cols = (out_first, T0, I0, plan.T[idx], plan.I_law[idx], np.asarray(t_after), np.asarray(a2_after),
                plan.beta[idx])
    _per_stroke_rows(idx, *row_cols, cols, None, by_kind)
    per_stroke = _summary_rows(getattr(opts, "summary_rows", True), cols, idx, row_cols)
    for g in by_kind.values():
        g["int_a2"]["change"] = _ratio(g["int_a2"]["after"], g["int_a2"]["before"])
        g["time_s"]["change"] = _ratio(g["time_s"]["after"], g["time_s"]["before"])
    reason_codes = _reason_codes(plan.reason)
    reasons = _reason_counts(reason_codes)
    law_T = float(plan.T[idx].sum()) if len(idx) else 0.0
    law_I = float(plan.I_law[idx].sum()) if len(idx) else 0.0
    # the passes' counts where they made them (analyse's, the last full measure's): the same
    # numbers without reading both files again
    lines_before = getattr(opts, "lines_in", None)
    if lines_before is None:
        lines_before = count_lines(in_path)
    lines_after = getattr(opts, "lines_out", None)
    if lines_after is None:
        lines_after = count_lines(written_path)
    size_after = os.path.getsize(written_path)
    out = {
        "input": in_path, "output": out_path, "profile": profile.name, "flavour": profile.flavour,
        "options": {"alpha": opts.alpha, "features": list(opts.features), "overshoot": opts.overshoot_r,
                    "max_slowdown": opts.max_slowdown_r, "max_segments": opts.max_segments},
        "strokes": {"candidates": len(cols), "retimed": int(len(idx)),
                    "not_retimed": {k: v for k, v in reasons.items() if k != "retimed"},
                    # the part of not_retimed that is a fault kept out of the file (planning,
                    # segments or emission raised, a non-finite number, the validator refused)
                    "faults": sum(v for k, v in reasons.items() if k.startswith(FAULT_PREFIXES))},
        "print_time_s": {"before": sim0.time_t, "after": sim1.time_t,
                         "change": _ratio(sim1.time_t, sim0.time_t)},
        "retimed_strokes": {
            "time_s": {"before": float(T0.sum()), "law": law_T, "after": float(t_after.sum())},
            "int_a2": {"before": float(I0.sum()), "law": law_I, "after": float(a2_after.sum()),
                       "change": _ratio(float(a2_after.sum()), float(I0.sum()))},
            "int_v2": {"before": float(V0.sum()), "after": float(v2_after.sum())},
            "firmware_vs_law": {"time": _ratio(float(t_after.sum()), law_T),
                                "int_a2": _ratio(float(a2_after.sum()), law_I)},
            "by_kind": by_kind,
        },
        # the headline: share of the file re-timed, the whole file's change, what was left and why
        "coverage": coverage(cols, pin, plan, sim0, sim1, idx, opts, reason_codes),
        "whole_file": {"before": sim0.as_dict(), "after": sim1.as_dict(),
                       "int_a2_change": _ratio(sim1.int_a2, sim0.int_a2),
                       "corner_dv2_change": _ratio(sim1.corner_dv2, sim0.corner_dv2)},
        "file": {"bytes_before": size_before, "bytes_after": size_after, "lines_before": lines_before,
                 "lines_after": lines_after},
        "elapsed_s": elapsed_t,
        # where the feature labels came from (the file's comments, or none: see features.selection_info)
        "features": getattr(opts, "feature_info", None),
        "per_stroke": per_stroke,
    }
    if per_stroke is None:
        del out["per_stroke"]
    if ringing is not None:                        # ahead of the long per-stroke list
        out["ringing"] = ringing_section(*ringing)
        if per_stroke is not None:
            out["per_stroke"] = out.pop("per_stroke")
    return out


_TWO52 = float(1 << 52)


def round_list(vals, nd):
    """[round(v, nd) for v in vals] (nd 0..15), the same objects' values, at a fraction of
    the cost for Python floats: round() is correctly rounded (the decimal D / 10^nd nearest
    v, ties to even, read back as the double nearest it).  D is rint(v * 10^nd) unless the
    product lies within 2 ulp of a tie (its rounding could have moved it across): there,
    and for any value not a float, not finite or with |v * 10^nd| >= 2^52, round() itself.
    D / 10^nd, both exact doubles, is one correctly rounded division: the nearest double."""
    n = len(vals)
    if n < ROUND_ARRAY_MIN:
        return [round(v, nd) for v in vals]
    out = round_array(np.array(vals, dtype=float), nd).tolist()
    if set(map(type, vals)) != _FLOAT_ONLY:
        for j, v in enumerate(vals):
            if type(v) is not float:      # (an int, a numpy scalar: its own __round__)
                out[j] = round(v, nd)
    return out


_FLOAT_ONLY = {float}
ROUND_ARRAY_MIN = 64           # round_list: shorter lists by round() alone


def round_array(x, nd):
    """round_list's numbers of a float64 array x, a float64 array (round() itself where
    rint could be off: see round_list)."""
    scale = float(10 ** nd)
    with np.errstate(all="ignore"):
        p = x * scale
        d = np.rint(p)
        out = d / scale
        ap = np.abs(p)
        frac = ap - np.floor(ap)
        slow = ~(ap < _TWO52) | (np.abs(frac - 0.5) <= 2.0 * np.spacing(ap))
    for j in np.flatnonzero(slow).tolist():
        out[j] = round(x.item(j), nd)
    return out


def _summary_rows(wanted, cols, idx, row_cols):
    """The summary's per_stroke rows as Options.summary_rows asks: True, a list of dicts;
    "table", a StrokeRows (the command line's --json and --report: made a row at a time as
    they are written or read); False, None (its text summary has none)."""
    if not wanted:
        return None
    rows = StrokeRows(cols, idx, *row_cols)
    return rows if wanted == "table" else list(rows)


def _per_stroke_rows(idx, out_first, t0, i0, t_law, i_law, t1, a21, beta, strokes, per_stroke, by_kind):
    """build_summary's per-stroke rows (appended to per_stroke; per_stroke None: the by_kind
    sums alone) and by_kind sums, in the order of idx (stroke indices into strokes: its
    StrokeColumns, or the list of strokes) (columns by row: lists, or arrays, whose rows are
    built on Python floats (tolist: the arrays' values) rather than numpy scalars: the same
    numbers, the same sums in the same order)."""
    cols = StrokeColumns.of(strokes)
    rows = np.asarray(idx, np.intp)
    if per_stroke is not None:
        per_stroke.extend(StrokeRows(cols, rows, out_first, t0, i0, t_law, i_law, t1, a21, beta))
    _by_kind_rows(cols.values("kind", rows), (t0, t_law, t1, i0, i_law, a21), by_kind)


def _as_list(col):
    """A column as a list (an array's values as Python numbers)."""
    return col.tolist() if isinstance(col, np.ndarray) else col


class StrokeRows(Sequence):
    """The summary's per-stroke rows held as columns (~130 bytes a row; the list of dicts
    held ~1.4 kB a row: 57 MB on the rectilinear plate, the --json run's peak), each row
    made as it is read: the dict the list held (the same keys in the same order, the same
    values of the same types).  The strokes' own fields (line, lines, kind, feature,
    layer, the rounded length and speeds) are read from their StrokeColumns at a chunk's
    rows as it is made, not copied at every row first (9 columns of the rows: ~3 MB on
    the rectilinear plate at the summary's peak).  Iterated a chunk of rows at a time
    (chunks()); a row by index, or by its first line (row_at_line: the report's lookup).
    Equal to a list of the same rows, as the list was."""

    CHUNK = 128              # rows made (and json.dumps encodes) at a time: ~0.6 MB
    BLOCK = 2048             # rows whose stroke fields are read (and rounded) at a time: ~150 kB
    ROUNDED = (("length_d", 4), ("v0", 3), ("v1", 3), ("v_feed", 3))
    __slots__ = ("n", "rows", "strokes", "coded", "cols", "_by_line", "_near")
    __hash__ = None

    def __init__(self, cols, rows, out_first, t0, i0, t_law, i_law, t1, a21, beta):
        """The rows of the strokes `rows` (indices into cols, a StrokeColumns, which the
        rows read as they are made: not changed after) with their columns by row (arrays
        or sequences); as many rows as the shortest column has (the rows zip them)."""
        self.rows = np.asarray(rows, np.intp)
        self.strokes = cols
        self.coded = [(list(cols.code_of[name]), cols.codes[name]) for name in ("kind", "feature", "layer")]
        self.cols = [c if isinstance(c, np.ndarray) else list(c)
                     for c in (out_first, t0, t_law, t1, i0, i_law, a21, beta)]
        self.n = min(map(len, [self.rows, *self.cols]))
        self._by_line = None
        self._near = (0, [])            # row_at_line's last chunk of rows: (its first row, the rows)

    def __len__(self):
        return self.n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._make(j, j + 1)[0] for j in range(*i.indices(self.n))]
        j = i.__index__()
        if j < 0:
            j += self.n
        if not 0 <= j < self.n:
            raise IndexError("StrokeRows index out of range")
        return self._make(j, j + 1)[0]

    def __iter__(self):
        for part in self.chunks():
            yield from part

    def chunks(self):
        """The rows, a list of up to CHUNK rows at a time (their stroke fields read a BLOCK
        of rows at a time: numpy's calls a chunk cost ~23 ms on the rectilinear plate)."""
        step = max(self.CHUNK, self.BLOCK)
        for a0 in range(0, self.n, step):
            b0 = min(a0 + step, self.n)
            fields = self._fields(a0, b0)
            for a in range(a0, b0, self.CHUNK):
                yield self._make(a, min(a + self.CHUNK, b0), fields, a0)

    def json_chunks(self):
        """The rows as dump_json writes them, compact, one a line (",\\n  " between rows),
        a chunk of rows at a time: each chunk one json.dumps of its list of rows (one
        encoder a chunk, where one a row cost ~12 k instructions: ~0.5 G on the
        rectilinear plate), cut where a row starts: '{"line": ' is found nowhere else (a
        quote inside a JSON string is escaped; the rows' other dicts start with "before")."""
        import json
        for part in self.chunks():
            yield json.dumps(part)[1:-1].replace(_ROW_SEP, _ROW_LINE)

    def __eq__(self, other):
        if isinstance(other, (list, StrokeRows)):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other))
        return NotImplemented

    def __repr__(self):
        return repr(list(self))

    def row_at_line(self, line):
        """The row whose stroke starts on (1-based) line `line`, or None (of several, the
        last: as a dict {row["line"]: row} kept it)."""
        if self._by_line is None:
            first = self.strokes.first_idx[self.rows[:self.n]] + 1
            order = np.argsort(first, kind="stable")
            self._by_line = (order, first[order])
        order, lines = self._by_line
        k = int(np.searchsorted(lines, line, side="right")) - 1
        return self._row_near(int(order[k])) if k >= 0 and lines[k] == line else None

    def _row_near(self, j):
        """Row j, made with the CHUNK of rows around it (the report asks the rows of its
        fences in file order: the rows' numpy reads once a chunk, not once a row; ~35 k
        rows on the gyroid plate).  A row asked again is the same dict: read, not changed,
        by its callers."""
        a, part = self._near
        if not a <= j < a + len(part):
            a = j - j % self.CHUNK
            part = self._make(a, min(a + self.CHUNK, self.n))
            self._near = (a, part)
        return part[j - a]

    def _fields(self, a, b):
        """The stroke fields of rows a .. b - 1 as the rows show them: [line, lines, the
        kind, feature and layer codes, the four rounded fields] (arrays, or lists)."""
        rows, strokes = self.rows[a:b], self.strokes
        return [strokes.first_idx[rows] + 1, strokes.n_moves[rows], *(code[rows] for _, code in self.coded),
                *(_rounded(strokes, name, rows, nd) for name, nd in self.ROUNDED)]

    def _make(self, a, b, fields=None, at=None):
        """Rows a .. b - 1, dicts (~3 a row, none in a cycle: no collection runs over them);
        fields: _fields of rows at .. (holding a .. b - 1), else read here."""
        if fields is None:
            fields, at = self._fields(a, b), a
        part = [c[a - at:b - at] for c in fields]
        lines, n_moves, r4, rv0, rv1, rvf = map(_as_list, part[:2] + part[5:])
        kinds, features, layers = (objfields.items(values, code) for (values, _), code in zip(self.coded, part[2:5]))
        out_first, t0, t_law, t1, i0, i_law, a21, beta = (_part(c, a, b) for c in self.cols)
        gc_was = gc.isenabled()
        gc.disable()
        try:
            return [{"line": line, "lines": nm, "kind": kind, "out_line": of + 1,
                     "feature": fe, "layer": la, "length_mm": ln,
                     "v0_mm_s": v0, "v1_mm_s": v1, "feed_mm_s": f,
                     "time_s": {"before": x0, "law": xl, "after": x1},
                     "int_a2": {"before": y0, "law": yl, "after": y1},
                     "beta_s2": be if -_INF < be < _INF else None}     # (math.isfinite: NaN and +-inf are None)
                    for line, nm, kind, of, fe, la, ln, v0, v1, f, x0, xl, x1, y0, yl, y1, be
                    in zip(lines, n_moves, kinds, out_first, features, layers, r4, rv0, rv1, rvf, t0, t_law, t1,
                           i0, i_law, a21, beta)]
        finally:
            if gc_was:
                gc.enable()


_ROW_SEP, _ROW_LINE = '}, {"line": ', '},\n  {"line": '     # rows in a JSON list; one a line


def _rounded(cols, name, rows, nd):
    """round_list of float field `name` at rows (cols a StrokeColumns), each value rounded
    once as the rows show it: a float64 array where all are floats (its tolist: the same
    floats), else the list."""
    col = cols.floats[name]
    if isinstance(col, np.ndarray) and len(rows) >= ROUND_ARRAY_MIN:
        return round_array(col[rows], nd)
    vals = round_list(cols.float_values(name, rows), nd)
    return np.array(vals, float) if set(map(type, vals)) <= _FLOAT_ONLY else vals


def _part(col, a, b):
    """col[a:b] as a list (an array's values as Python numbers)."""
    return _as_list(col[a:b])


def _by_kind_rows(kinds, cols, by_kind):
    """The by-kind sums: the old row-by-row loop's additions, as it wrote them (the same `+=`
    on the same floats in the same order: NaN and inf sums too keep their bits): in rows,
    each sum an add.accumulate (a strictly sequential sum) from the total so far over the
    kind's values in row order."""
    n = len(kinds)
    # (a float64 array is taken as it is: the values np.array makes of its tolist())
    cols = [c if isinstance(c, np.ndarray) and c.dtype == np.float64 and c.ndim == 1 else _as_list(c) for c in cols]
    if n < 64 or any(len(c) != n for c in cols) or any(not isinstance(c, np.ndarray)
                                                       and set(map(type, c)) != _FLOAT_ONLY for c in cols):
        _by_kind_loop(kinds, list(map(_as_list, cols)), by_kind)
        return
    code_of, code = value_codes(kinds)          # (the kinds in the order of their first row)
    arrs = [np.asarray(c, dtype=float) for c in cols]
    for kind, c in code_of.items():
        g = _kind_group(by_kind, kind)
        m = code == c
        g["retimed"] += int(m.sum())
        gt, ga = g["time_s"], g["int_a2"]
        for d, key, x in ((gt, "before", arrs[0]), (gt, "law", arrs[1]), (gt, "after", arrs[2]),
                          (ga, "before", arrs[3]), (ga, "law", arrs[4]), (ga, "after", arrs[5])):
            d[key] = float(np.add.accumulate(np.concatenate(([d[key]], x[m])))[-1])


def _kind_group(by_kind, kind):
    """by_kind[kind], made empty if it is not there yet."""
    g = by_kind.get(kind)
    if g is None:
        g = by_kind[kind] = {"retimed": 0, "time_s": {"before": 0.0, "law": 0.0, "after": 0.0},
                             "int_a2": {"before": 0.0, "law": 0.0, "after": 0.0}}
    return g


def _by_kind_loop(kinds, cols, by_kind):
    """_per_stroke_rows' by-kind sums row by row (the code before the rows: short or odd
    columns, and the tests' reference)."""
    for kind, x0, xl, x1, y0, yl, y1 in zip(kinds, *cols):
        g = _kind_group(by_kind, kind)
        g["retimed"] += 1
        gt, ga = g["time_s"], g["int_a2"]
        gt["before"] += x0
        gt["law"] += xl
        gt["after"] += x1
        ga["before"] += y0
        ga["law"] += yl
        ga["after"] += y1


_INF = math.inf


def dump_json(summary: dict, fh) -> None:
    """Write `summary` as JSON: indented as json.dump(indent=1) writes it, except that a
    top-level list of rows (per_stroke) has one compact row a line.  json's indenting
    encoder is pure Python: the gyroid plate's 11 MB summary took 0.59 s CPU, written this
    way (the C encoder, row by row) 0.23 s.  json.load reads the same object back.  A
    StrokeRows is written as the list of its rows, made and written a chunk at a time."""
    import json
    fh.write("{")
    sep = "\n "
    for k, v in summary.items():
        fh.write(sep + json.dumps(k) + ": ")
        chunks = _row_chunks(v)
        if chunks is not None:
            fh.write("[\n  ")
            between = ""
            for text in chunks:
                fh.write(between)
                fh.write(text)
                between = ",\n  "
            fh.write("\n ]")
        else:
            fh.write(json.dumps(list(v) if isinstance(v, StrokeRows) else v, indent=1).replace("\n", "\n "))
        sep = ",\n "
    fh.write("\n}" if summary else "}")


def _row_chunks(v):
    """The text of v's rows where dump_json writes it one row a line (a list of more than
    one row, each a dict or a list; a StrokeRows of more than one row): compact rows joined
    by ",\\n  ", in chunks; else None."""
    import json
    if isinstance(v, StrokeRows):
        return v.json_chunks() if len(v) > 1 else None
    if isinstance(v, list) and len(v) > 1 and all(isinstance(r, (dict, list)) for r in v):
        return (",\n  ".join(json.dumps(r) for r in v),)
    return None
