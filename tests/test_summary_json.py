"""The --json summary writer (summary.dump_json): the object json.load reads back is the
summary, whatever its shape; indented like json.dump(indent=1) except the rows of a
top-level list of rows, one compact row a line."""
import io
import json
import math

from hypothesis import given, settings, strategies as st

from gcode_opt.summary import dump_json

_scalars = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(allow_nan=False, allow_infinity=False),
                     st.text(max_size=8))
_values = st.recursive(_scalars, lambda c: st.one_of(st.lists(c, max_size=4),
                                                      st.dictionaries(st.text(max_size=6), c, max_size=4)),
                       max_leaves=20)


def _round_trip(obj):
    buf = io.StringIO()
    dump_json(obj, buf)
    return buf.getvalue(), json.loads(buf.getvalue())


@settings(max_examples=300, deadline=None)
@given(st.dictionaries(st.text(max_size=8), _values, max_size=6))
def test_reads_back_as_written(obj):
    text, back = _round_trip(obj)
    assert back == obj
    assert text == json.dumps(obj, indent=1) or any(
        isinstance(v, list) and len(v) > 1 and all(isinstance(r, (dict, list)) for r in v) for v in obj.values())


def test_rows_one_a_line_and_the_rest_indented():
    summary = {"input": "a.gcode", "strokes": {"retimed": 2, "faults": 0},
               "per_stroke": [{"line": 3, "time_s": {"before": 0.1, "after": 0.2}}, {"line": 9, "kind": "arc"}],
               "empty": [], "one": [{"x": 1}], "whole_file": {"int_a2_change": -0.25}}
    text, back = _round_trip(summary)
    assert back == summary
    lines = text.splitlines()
    assert '  {"line": 3, "time_s": {"before": 0.1, "after": 0.2}},' in lines
    assert '  {"line": 9, "kind": "arc"}' in lines
    # everything but the rows as json.dump(indent=1) writes it
    assert ' "strokes": {' in lines and '  "retimed": 2,' in lines and ' "one": [' in lines


def test_nan_and_inf_as_json_dump_writes_them():
    summary = {"rows": [{"a": math.inf}, {"a": -math.inf}], "x": float("nan")}
    text, _ = _round_trip(summary)
    assert '{"a": Infinity}' in text and '"x": NaN' in text


def test_empty_summary():
    assert _round_trip({}) == ("{}", {})
