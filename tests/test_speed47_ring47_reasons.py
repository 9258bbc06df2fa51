"""summary's reasons (issue 8, s47): build_summary's not_retimed counts and coverage's
reason codes made once (_reason_codes, _reason_counts), the texts as they are where every
reason is a str (no str() call a stroke), against the code they replaced, kept here
verbatim: Counter(map(str, plan.reason)) (key order, counts) and coverage's own
value_codes(list(map(str, plan.reason[:n]))) (coverage with and without the codes handed
in: the same dict, its keys' order too)."""
from __future__ import annotations

from collections import Counter
from operator import attrgetter
from types import SimpleNamespace

import numpy as np
import pytest

from gcode_opt import summary as sm
from gcode_opt.distinct import value_codes
from gcode_opt.stroke_columns import _coded      # (summary._feature_codes until session 50)


def ref_counts(reason):
    """882d7e9 build_summary's reasons, verbatim."""
    return Counter(map(str, reason))


class Text(str):
    """A str subclass: str() of it is a plain str (another object, the same text)."""


def _obj(values):
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def cases():
    rng = np.random.default_rng(47)
    texts = ["retimed", "no law within limits", "original is better within the time budget", "",
             "error: planning (non-finite)"]
    plain = [texts[k] for k in rng.integers(0, len(texts), 3000)]
    yield "plain", _obj(plain)
    yield "list", list(plain)
    yield "empty", _obj([])
    yield "one", _obj(["retimed"])
    odd = list(plain)
    odd[5] = np.str_("retimed")              # the same text, a numpy scalar
    odd[17] = Text("no law within limits")   # a subclass
    odd[40] = None                           # str(None): "None"
    odd[41] = 3                              # str(3): "3"
    yield "odd", _obj(odd)
    yield "unicode", np.array(plain)         # a fixed-width unicode array (tolist: str)


@pytest.mark.parametrize("name,reason", list(cases()), ids=[c[0] for c in cases()])
def test_counts_as_counter(name, reason):
    want = ref_counts(reason)
    got = sm._reason_counts(sm._reason_codes(reason))
    assert list(got.items()) == list(want.items())
    assert all(type(k) is str and type(v) is int for k, v in got.items())


@pytest.mark.parametrize("name,reason", list(cases()), ids=[c[0] for c in cases()])
def test_codes_as_value_codes(name, reason):
    """The codes coverage read before: value_codes of the str of each reason."""
    want_of, want = value_codes(list(map(str, reason)))
    got_of, got = sm._reason_codes(reason)
    assert list(got_of.items()) == list(want_of.items())
    assert got.tolist() == want.tolist()


def _coverage_args(reason, n):
    rng = np.random.default_rng(5)
    strokes = [SimpleNamespace(feature="f%d" % (k % 3)) for k in range(n)]
    pin = SimpleNamespace(T_orig=rng.uniform(0.1, 1.0, n), I_orig=rng.uniform(0.0, 5.0, n))
    plan = SimpleNamespace(reason=reason)
    sim0 = SimpleNamespace(int_a2=1e4, time_t=1e3, barrier_dwell_t=2.0)
    sim1 = SimpleNamespace(int_a2=9e3, time_t=1.1e3)
    idx = np.flatnonzero(np.asarray([str(r) == "retimed" for r in reason[:n]], bool))
    return strokes, pin, plan, sim0, sim1, idx


@pytest.mark.parametrize("name,reason", [c for c in cases() if c[0] in ("plain", "odd")], ids=["plain", "odd"])
def test_coverage_with_codes(name, reason):
    """coverage with build_summary's codes (made over every reason, the caller's kept
    intact) is coverage making its own, as before (also over fewer strokes than reasons)."""
    for n in (len(reason), len(reason) - 100):
        args = _coverage_args(reason, n)
        want = sm.coverage(*args, None, value_codes(list(map(str, reason[:n]))))   # (882d7e9's codes)
        assert repr(sm.coverage(*args)) == repr(want)
        codes = sm._reason_codes(reason)
        keep = codes[1].copy()
        got = sm.coverage(*args, None, codes)
        assert repr(got) == repr(want)
        assert codes[1].tolist() == keep.tolist()


def ref_feature_codes(strokes):
    """882d7e9 coverage's feature codes, verbatim."""
    return value_codes(list(map(attrgetter("feature"), strokes)))


def _strokes(n):
    feats = ["perimeter", "infill", None, "solid infill", Text("infill")]
    return [SimpleNamespace(feature=feats[k * 7 % len(feats)]) for k in range(n)]


@pytest.mark.parametrize("strokes", [_strokes(500), tuple(_strokes(50)), _strokes(0), _strokes(1)],
                         ids=["list", "tuple", "empty", "one"])
def test_feature_codes(strokes):
    want_of, want = ref_feature_codes(strokes)
    got_of, got = _coded(strokes, "feature")
    assert list(got_of.items()) == list(want_of.items())
    assert [type(k) for k in got_of] == [type(k) for k in want_of]
    assert got.tolist() == want.tolist()


@pytest.mark.parametrize("bad,exc", [(SimpleNamespace(), AttributeError), (SimpleNamespace(feature=[1]), TypeError)],
                         ids=["missing", "unhashable"])
def test_feature_codes_raise_as_before(bad, exc):
    strokes = _strokes(20)
    strokes[13] = bad
    with pytest.raises(exc):
        ref_feature_codes(strokes)
    with pytest.raises(exc):
        _coded(strokes, "feature")
