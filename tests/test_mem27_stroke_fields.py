"""The strokes' fields in the compiled StrokeBase (issue 8, round 27: memory).

strokes.Stroke subclasses firmware/_core.c's StrokeBase where the compiled core is used:
the fields that are always a float (or a float or None) are kept there as doubles and
first_idx / last_idx as 64-bit ints, not as objects of their own (~24-32 bytes each; the
gyroid plate's 35 k strokes held ~13 MB of them).  What every reader sees must not
change: the same values to the bit and the same types.  The reference is the
pure-Python class (the __slots__ class GCODE_OPT_PURE_PYTHON=1 gives), made here from
the same methods with FIELDS as slots and swapped in where the package names Stroke:
analyse must make strokes whose every field is the same, and the whole job the same
bytes and summary; and GCODE_OPT_PURE_PYTHON=1 itself must give the plain class and the
same output."""
from __future__ import annotations

import gc
import json
import math
import os
import struct
import subprocess
import sys
import tracemalloc

import pytest

from gcode_opt import chains, pipeline, stroke_columns, strokes
from gcode_opt.profile import load_profile

SAMPLES = "sample_gcode/"
_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")
BASE = strokes._BASE
pytestmark = pytest.mark.skipif(BASE is None, reason="the compiled core is not built (or pure Python is asked)")

DOUBLES = ("x0", "y0", "ux", "uy", "length_d", "e_per_mm", "v0", "v1", "time_t", "int_a2", "int_v2")
NONE_ABLE = ("_pux", "_puy", "_nux", "_nuy", "_ss_e")
INTS = ("first_idx", "last_idx")


def _python_stroke():
    """The pure-Python Stroke: the class's own methods and properties, FIELDS as slots."""
    skip = {"__slots__", "__dict__", "__weakref__", "__module__", "__qualname__"}
    ns = {k: v for k, v in strokes.Stroke.__dict__.items() if k not in skip}
    ns["__slots__"] = strokes.FIELDS
    ns["__module__"] = strokes.__name__
    return type("Stroke", (object,), ns)


@pytest.fixture
def python_strokes(monkeypatch):
    """Swap the pure-Python class in wherever the package holds the name Stroke."""
    cls = _python_stroke()
    for mod in (strokes, pipeline, chains, stroke_columns):
        monkeypatch.setattr(mod, "Stroke", cls)
    monkeypatch.setattr(strokes, "_new", object.__new__)
    return cls


def _val(v):
    """A field's value with its type, floats by their bit patterns (-0.0 != 0.0, NaN == NaN)."""
    if type(v) is float:
        return ("float", struct.pack("<d", v))
    if type(v).__name__ == "array":
        return ("array", v.typecode, v.tobytes())
    if isinstance(v, strokes.Points):
        return ("Points", v.xy.tobytes())
    if v is None or type(v) in (int, bool, str):
        return (type(v).__name__, v)
    slots = getattr(type(v), "__slots__", None)          # state.Limits, state.Arc: by value
    return (type(v).__name__, id(v) if slots is None else tuple(_val(getattr(v, f, None)) for f in slots))


def _fields(st):
    return tuple((n, _val(getattr(st, n))) for n in strokes.FIELDS if n not in ("curv", "chain_T"))


def test_fields_read_back_as_set():
    import numpy as np
    st = strokes._new(strokes.Stroke)
    assert isinstance(st, BASE)
    for n in DOUBLES + NONE_ABLE:
        for x in (1.25, -0.0, 5e-324, -1e308, math.inf, 0.1 + 0.2):
            setattr(st, n, x)
            got = getattr(st, n)
            assert type(got) is float and struct.pack("<d", got) == struct.pack("<d", x), (n, x)
        setattr(st, n, math.nan)
        assert math.isnan(getattr(st, n))
        # another type (never the package's writers: the tests') is kept as the object it is
        for x in (7, np.float64(2.5), "x", None, 1 << 70):
            setattr(st, n, x)
            assert getattr(st, n) is x, (n, x)
        setattr(st, n, 3.5)
        assert type(getattr(st, n)) is float and getattr(st, n) == 3.5
        delattr(st, n)
        with pytest.raises(AttributeError):
            getattr(st, n)
        setattr(st, n, -1.5)
        assert getattr(st, n) == -1.5
    for n in NONE_ABLE:
        setattr(st, n, 2.5)
        setattr(st, n, None)
        assert getattr(st, n) is None
    for n in INTS:
        for x in (0, 7, 1 << 40, -3, -(1 << 63)):
            setattr(st, n, x)
            assert type(getattr(st, n)) is int and getattr(st, n) == x
        for x in (1.0, True, None, np.int64(4), 1 << 64):
            setattr(st, n, x)
            assert getattr(st, n) is x, (n, x)
        setattr(st, n, 5)
        assert getattr(st, n) == 5 and type(getattr(st, n)) is int
    # the None-able pairs through their properties
    st.prev_u, st.next_u = (0.6, -0.8), None
    assert st.prev_u == (0.6, -0.8) and st.next_u is None
    st.start_state = (1.5, 1000.0, 0.5)
    assert st.start_state == (1.5, 1000.0, 0.5)
    st.start_state = None
    assert st.start_state is None and st._ss_a is None


def test_no_float_objects_of_its_own():
    """The stroke refers to no float object of the inlined fields (gc's view: tp_traverse),
    and takes the slotted class's room and one pointer (the dict of values of other types)."""
    profile = load_profile("prusa-mk3s")
    sts, _ = pipeline.analyse(SAMPLES + "prusa_gyroid.gcode", profile, pipeline.Options())
    assert len(sts) > 500 and all(type(s) is strokes.Stroke for s in sts)
    shared = {"z", "v_feed", "accel", "_ss_a", "_ss_c"}          # the run's objects (shared)
    for s in sts:
        floats = [o for o in gc.get_referents(s) if type(o) is float]
        assert len(floats) <= len(shared), (s.first_idx, floats)
    assert sys.getsizeof(sts[0]) <= 16 + 8 * (len(strokes.FIELDS) + 1) + 16 + 8      # (+1: the odd values' dict)


def _analyse(path, prof):
    return pipeline.analyse(path, load_profile(prof), pipeline.Options())[0]


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_concentric_arcs.gcode", "voron24"),
                                       ("prusa_klipper.gcode", "voron24"), ("cura_box.gcode", "ender3"),
                                       ("bridges.gcode", "prusa-mk3s")])
def test_analyse_strokes_as_the_python_class(monkeypatch, name, prof):
    path = (_CORPUS if name.startswith("bridges") else SAMPLES) + name
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    got = _analyse(path, prof)
    cls = _python_stroke()
    for mod in (strokes, pipeline, chains, stroke_columns):
        monkeypatch.setattr(mod, "Stroke", cls)
    monkeypatch.setattr(strokes, "_new", object.__new__)
    ref = _analyse(path, prof)
    assert all(type(s) is cls for s in ref) and all(isinstance(s, BASE) for s in got)
    assert len(got) == len(ref) > 100
    kinds = set()
    for a, b in zip(got, ref):
        assert _fields(a) == _fields(b), a.first_idx
        assert (a.prev_u, a.next_u, a.start_state, a.n_moves) == (b.prev_u, b.next_u, b.start_state, b.n_moves)
        assert a.ends_d.tobytes() == b.ends_d.tobytes()
        # the core's arrays take no more room than Python's (made from lists: exact)
        assert a._ends is None or sys.getsizeof(a._ends) <= sys.getsizeof(b._ends)
        assert a.pts is None or sys.getsizeof(a.pts.xy) == sys.getsizeof(b.pts.xy)
        kinds.add(a.kind)
    assert "line" in kinds and ("curve" in kinds or name != "prusa_gyroid.gcode")
    assert "arc" in kinds or name != "prusa_concentric_arcs.gcode"


def _process(path, out, prof):
    opts = pipeline.Options()
    opts.ringing = False
    s = pipeline.process(path, str(out), load_profile(prof), opts)
    s = {k: v for k, v in s.items() if k not in ("timing_s", "input", "output") and "elapsed" not in k}
    return out.read_bytes(), json.dumps(s, sort_keys=True, default=str)


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_concentric_arcs.gcode", "voron24")])
def test_process_as_the_python_class(tmp_path, monkeypatch, name, prof):
    got = _process(SAMPLES + name, tmp_path / "a.gcode", prof)
    cls = _python_stroke()
    for mod in (strokes, pipeline, chains, stroke_columns):
        monkeypatch.setattr(mod, "Stroke", cls)
    monkeypatch.setattr(strokes, "_new", object.__new__)
    ref = _process(SAMPLES + name, tmp_path / "b.gcode", prof)
    assert got[0] == ref[0]
    assert got[1] == ref[1]


def test_traced_memory_a_stroke_less(monkeypatch):
    """analyse's strokes take ~300 bytes a stroke less than with the slotted class (the
    prusa_gyroid sample: 13 of its float fields and 2 ints a stroke no longer objects)."""
    path = SAMPLES + "prusa_gyroid.gcode"

    def traced():
        _analyse(path, "prusa-mk3s")               # (imports, caches: warmed)
        gc.collect()
        tracemalloc.start()
        try:
            sts = _analyse(path, "prusa-mk3s")
            gc.collect()
            return tracemalloc.get_traced_memory()[0], len(sts)
        finally:
            tracemalloc.stop()

    mine, n = traced()
    cls = _python_stroke()
    for mod in (strokes, pipeline, chains, stroke_columns):
        monkeypatch.setattr(mod, "Stroke", cls)
    monkeypatch.setattr(strokes, "_new", object.__new__)
    ref, n_ref = traced()
    assert n == n_ref
    assert (ref - mine) / n > 250, ((ref - mine) / n)


def test_pure_python_path(tmp_path):
    """GCODE_OPT_PURE_PYTHON=1: the plain slotted class, and the same bytes and summary."""
    with open(SAMPLES + "prusa_gyroid.gcode", encoding="utf-8", newline="") as fh:     # (its first 4000 lines:
        head = [next(fh) for _ in range(4000)]                                          # the Python model is slow)
    path = str(tmp_path / "head.gcode")
    with open(path, "w", encoding="utf-8", newline="") as fh:
        fh.writelines(head)
    code = ("import sys, gcode_opt.strokes as s; from gcode_opt.cli import main\n"
            "assert s._BASE is None and s.Stroke.__bases__ == (object,) and s.Stroke.__slots__ == s.FIELDS\n"
            "sys.exit(main(sys.argv[1:]))\n")
    outs = []
    for pure in ("1", "0"):
        env = dict(os.environ, GCODE_OPT_PURE_PYTHON=pure)
        if pure == "0":
            code = code.replace("s._BASE is None and s.Stroke.__bases__ == (object,)", "s._BASE is not None")
        out, js = tmp_path / f"o{pure}.gcode", tmp_path / f"o{pure}.json"
        r = subprocess.run([sys.executable, "-c", code, "process", path, "-o", str(out), "--json", str(js), "-q",
                            "--no-ringing", "--profile", "prusa-mk3s"], env=env, capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert out.read_bytes() != open(path, "rb").read()          # (strokes re-timed: not left as it was)
        s = json.loads(js.read_text())
        s = {k: v for k, v in s.items() if k not in ("timing_s", "input", "output") and "core" not in k
             and "elapsed" not in k}
        outs.append((out.read_bytes(), json.dumps(s, sort_keys=True)))
    assert outs[0][0] == outs[1][0]
    assert outs[0][1] == outs[1][1]


def test_line_spans_and_put_sums_as_attribute_reads_and_writes():
    """strokes.line_spans / put_sums in the core (StrokeBase read and written directly)
    against the attribute reads and writes they replace, and their fallback for a list
    holding another kind of stroke."""
    import copy

    import numpy as np
    sts = _analyse(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
    lo, hi = strokes.line_spans(sts)
    assert lo.dtype == hi.dtype == np.int64
    assert lo.tolist() == [s.first_idx for s in sts] and hi.tolist() == [s.last_idx for s in sts]
    cls = _python_stroke()
    twins = []
    for s in sts[:300]:
        t = object.__new__(cls)
        for n in strokes.FIELDS:
            setattr(t, n, getattr(s, n))
        twins.append(t)
    rng = np.random.default_rng(5)
    n = len(twins)
    got = rng.integers(0, 4, n).astype(np.int64)
    v0, v1, t_, a2, v2 = (rng.standard_normal(n) * 10.0 ** rng.integers(-300, 300, n) for _ in range(5))
    v0[:3] = (-0.0, np.nan, np.inf)
    mine = sts[:300]
    strokes.put_sums(mine, got, v0, v1, t_, a2, v2)
    strokes.put_sums(twins, got, v0, v1, t_, a2, v2)              # (not StrokeBase objects: Python's loop)
    assert [_fields(a) for a in mine] == [_fields(b) for b in twins]
    odd = copy.copy(mine[7])
    odd.last_idx = np.int64(odd.last_idx)                         # (a line number kept as an object)
    for other in (mine[:5] + twins[5:10], mine[:9] + [odd]):
        a_lo, a_hi = strokes.line_spans(other)                    # (declined by the core: attribute reads)
        assert a_lo.tolist() == [s.first_idx for s in other] and a_hi.tolist() == [s.last_idx for s in other]
    odd.v0 = np.float64(odd.v0)
    strokes.put_sums([odd], got[:1] | 1, v0, v1, t_, a2, v2)     # (a float written over it: a float)
    assert type(odd.v0) is float and struct.pack("<d", odd.v0) == struct.pack("<d", v0[0])
    with pytest.raises(ValueError):
        strokes._CORE.stroke_put_sums(mine, got[:2], v0, v1, t_, a2, v2)
    with pytest.raises(ValueError):
        strokes._CORE.stroke_lines(mine, np.empty(n), np.empty(n, np.int64))


def test_copy_and_pickle_as_the_python_class():
    """copy.deepcopy / pickle of a stroke (StrokeBase has no slots to copy by: Stroke's
    __reduce__) give what the slotted class's give: every field."""
    import copy
    import pickle
    sts = _analyse(SAMPLES + "prusa_concentric_arcs.gcode", "voron24")
    cls = _python_stroke()
    for s in sts[:200]:
        t = object.__new__(cls)
        for n in strokes.FIELDS:
            setattr(t, n, getattr(s, n))
        for a, b in ((copy.deepcopy(s), copy.deepcopy(t)), (copy.copy(s), copy.copy(t)),
                     (pickle.loads(pickle.dumps(s)), None)):
            assert type(a) is strokes.Stroke
            if b is not None:
                assert _fields(a) == _fields(b)
            else:
                assert [_val(getattr(a, n)) for n in DOUBLES + NONE_ABLE + INTS] == \
                       [_val(getattr(s, n)) for n in DOUBLES + NONE_ABLE + INTS]
