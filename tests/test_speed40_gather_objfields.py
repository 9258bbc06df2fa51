"""Issue 8 (s40, "gather"): fields of many objects read in one compiled pass
(gcode_opt/objfields.py over laws/_curvecore.c obj_floats / obj_codes / obj_ids) in place
of np.fromiter(map(attrgetter(name), objs), ...).

Each function against the Python it replaces on varied objects (slots, a __dict__, a
property, the compiled StrokeBase, values of other types, missing attributes), and each
call site against its own fallback (the objfields function answering None: the code as
it was) on real sample files, bit for bit."""
import os
import random
from operator import attrgetter

import numpy as np
import pytest

from gcode_opt import chains, curves, distinct, objfields, pipeline, schedule, segments
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")

needs_core = pytest.mark.skipif(objfields._CORE is None or objfields._FLOATS is None, reason="curve core not built")


_UNSET = object()


class Slots:
    __slots__ = ("a", "b", "k")

    def __init__(self, a, b, k=_UNSET):
        self.a, self.b = a, b
        if k is not _UNSET:
            self.k = k


class Plain:
    def __init__(self, a, b, k=None):
        self.a, self.b, self.k = a, b, k


class Prop(Slots):
    __slots__ = ()

    def __init__(self, a, b=None, k=_UNSET):
        self.a = a

    @property
    def b(self):
        return self.a * 2.0


class SlotsSub(Slots):              # (a subclass: its own type, the base's slots)
    __slots__ = ("extra",)


def _floats_ref(objs, names):
    """The reading the callers made: np.fromiter a field, or None where it raises."""
    try:
        cols = [np.fromiter(map(attrgetter(f), objs), float, len(objs)) for f in names]
    except (TypeError, ValueError, AttributeError):
        return None
    return np.stack(cols, axis=1) if cols else np.empty((len(objs), 0))


def _rand_objs(rng, n, mixed):
    out = []
    for _ in range(n):
        a = rng.choice([rng.uniform(-1e3, 1e3), float("nan"), -0.0, float("inf"), True, False, 1e-310])
        b = rng.uniform(-5, 5)
        kind = rng.randrange(4)
        o = Slots(a, b) if kind == 0 else Plain(a, b) if kind == 1 else SlotsSub(a, b) if kind == 2 else Prop(a, 0.0)
        out.append(o)
    if mixed:
        i = rng.randrange(n)
        out[i].a = rng.choice([1, np.float64(2.5), np.float64(-0.0), np.float32(0.1), None, "x", 2 ** 70])
    return out


@needs_core
@pytest.mark.parametrize("seed", range(12))
def test_floats_as_fromiter(seed):
    rng = random.Random(seed)
    objs = _rand_objs(rng, rng.randrange(1, 60), mixed=seed % 3 == 2)
    for names in (("a",), ("a", "b"), ("b", "a", "a")):
        got, ref = objfields.floats(objs, names), _floats_ref(objs, names)
        if ref is None or any(type(getattr(o, f)) not in (float, bool, np.float64) for o in objs for f in names):
            assert got is None
        else:
            assert got is not None and got.shape == ref.shape
            assert got.tobytes() == ref.tobytes()
    assert objfields.floats(objs + [Slots(1.0, 2.0)], ("k",)) is None       # k unset: no value
    f64 = [Slots(np.float64(rng.uniform(-9, 9)), rng.choice([np.float64(-0.0), 1.5, True])) for _ in range(9)]
    assert objfields.floats(f64, ("a", "b")).tobytes() == _floats_ref(f64, ("a", "b")).tobytes()
    assert objfields.floats(tuple(objs), ("a",)) is None                              # not a list
    assert objfields.floats([], ("a",)).shape == (0, 1)


@needs_core
@pytest.mark.parametrize("seed", range(8))
def test_codes_as_dict_lookups(seed):
    rng = random.Random(seed)
    words = ["travel", "perimeter", "infill", "", None, 3, 3.0, "infill "]
    vals = [rng.choice(words) for _ in range(rng.randrange(0, 200))]
    # value_codes' codes (name None, add): the same dict, in the same order, the same codes
    code_of = {}
    got = objfields.codes(vals, None, code_of, add=True)
    ref_of = {v: c for c, v in enumerate(dict.fromkeys(vals))}
    assert list(code_of.items()) == list(ref_of.items())
    assert got.dtype == np.intp and got.tolist() == [ref_of[v] for v in vals]
    # an attribute coded by a fixed dict: a value not in it answers None
    objs = [Plain(0.0, 0.0, k=v) for v in vals]
    fixed = {"travel": 0, "perimeter": 1, "infill": 2, "": 3, None: 4, 3: 5}
    got = objfields.codes(objs, "k", fixed)
    if all(v in fixed for v in vals):
        assert got.tolist() == [fixed[v] for v in vals]
    else:
        assert got is None
    # code_of None: the ints themselves (an int only)
    ints = [rng.randrange(-2 ** 62, 2 ** 62) for _ in range(50)]
    assert objfields.codes([Slots(0.0, 0.0, k=i) for i in ints], "k", None).tolist() == ints
    assert objfields.codes([Slots(0.0, 0.0, k=i) for i in ints + [True]], "k", None) is None
    assert objfields.codes([Slots(0.0, 0.0, k=i) for i in ints + [2 ** 64]], "k", None) is None
    assert objfields.codes([Slots(0.0, 0.0, k=[1])], "k", {}, add=True) is None     # unhashable


@needs_core
@pytest.mark.parametrize("seed", range(6))
def test_ids_as_dict_of_ids(seed):
    rng = random.Random(seed)
    pool = [Plain(1.0, 2.0), Plain(1.0, 2.0), None, "s", Slots(0.0, 1.0)]
    objs = [Slots(0.0, 0.0, k=rng.choice(pool)) for _ in range(rng.randrange(0, 300))]
    got = objfields.ids(objs, "k")
    lims = list(map(attrgetter("k"), objs))
    uniq = dict(zip(map(id, lims), lims))
    at = dict(zip(uniq, range(len(uniq))))
    firsts, which = got
    assert [id(x) for x in firsts] == list(uniq)
    assert which.tolist() == [at[id(x)] for x in lims]
    assert objfields.ids(objs + [Slots(0.0, 0.0)], "k") is None         # an unset k


def test_none_without_core(monkeypatch):
    monkeypatch.setattr(objfields, "_FLOATS", None)
    monkeypatch.setattr(objfields, "_CODES", None)
    monkeypatch.setattr(objfields, "_IDS", None)
    objs = [Slots(1.0, 2.0, k=1)]
    assert objfields.floats(objs, ("a",)) is None
    assert objfields.codes(objs, "k", None) is None
    assert objfields.ids(objs, "k") is None


def _no_core(monkeypatch):
    monkeypatch.setattr(objfields, "_FLOATS", None)
    monkeypatch.setattr(objfields, "_CODES", None)
    monkeypatch.setattr(objfields, "_IDS", None)


def _site_figures(name, prof, corners):
    """What every converted call site makes on a sample file's strokes (plan inputs, kind
    codes, limits, overshoots, line classes, value codes, the budget run's plan)."""
    profile = load_profile(prof)
    opts = pipeline.Options(corner_budget_r=corners)
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    out = [a.tobytes() for a in (pin.L, pin.v_cap, pin.a_cap, schedule._kind_codes(strokes),
                                 schedule._overshoots(strokes, opts), *schedule._lim_columns(strokes, profile),
                                 segments.line_classes(strokes))]
    lims, which = curves._lims_which(strokes)
    out += [len(lims), all(st.lim is lims[w] for st, w in zip(strokes, which.tolist())), which.dtype, which.tobytes(), segments._jerk_steps(strokes).tobytes()]
    code_of, code = distinct.value_codes(list(map(attrgetter("feature"), strokes)))
    out += [list(code_of.items()), code.tobytes()]
    plan = schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    out += [plan.retime.tobytes(), list(plan.reason), plan.t_pred.tobytes(), plan.a2_pred.tobytes(),
            plan.T.tobytes(), plan.beta.tobytes()]
    V0 = objfields.float_col(strokes, "int_v2")
    out.append(None if V0 is None else V0.tobytes())
    return out


def _laws_of_figures(name, prof, monkeypatch):
    """What chains._laws_of answered on a sample file's planning (each array's bytes)."""
    seen = []
    real = chains._laws_of

    def laws_of(Qs, items, profile, gs=None):
        got = real(Qs, items, profile, gs)
        seen.append([a.tobytes() if isinstance(a, np.ndarray) else len(a) for a in got])
        return got
    monkeypatch.setattr(chains, "_laws_of", laws_of)
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    monkeypatch.setattr(chains, "_laws_of", real)
    return seen


@needs_core
@pytest.mark.parametrize("name,prof", [("prusa_gyroid_fullspeed_klipper.gcode", "voron24"),
                                       ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s")])
def test_laws_of_as_its_fallback(name, prof, monkeypatch):
    new = _laws_of_figures(name, prof, monkeypatch)
    _no_core(monkeypatch)
    old = _laws_of_figures(name, prof, monkeypatch)
    assert new and new == old


def test_a_caps_as_python_min():
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    opts.ringing = False
    strokes, _ = pipeline.analyse(os.path.join(SAMPLES, "prusa_gyroid.gcode"), profile, opts)
    rng = random.Random(5)
    for st in strokes:                  # (each stroke its own acceleration, some above the limits)
        st.accel = rng.choice([rng.uniform(100.0, 3000.0), float(st.lim.ax_max), 1e9])
    ref = [min(st.accel, st.lim.ax_max, st.lim.ay_max) for st in strokes]
    got = curves._a_caps(strokes)
    assert np.array(ref, float).tobytes() == got.tobytes()
    strokes[3].accel = 1500                             # an int: the list itself
    assert curves._a_caps(strokes) == [min(st.accel, st.lim.ax_max, st.lim.ay_max) for st in strokes]


@needs_core
@pytest.mark.parametrize("name,prof,corners", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3),
                                               ("prusa_gyroid_fullspeed_klipper.gcode", "voron24", 0.0),
                                               ("prusa_gyroid.gcode", "prusa-mk3s", 0.0)])
def test_sites_as_their_fallback(name, prof, corners, monkeypatch):
    new = _site_figures(name, prof, corners)
    _no_core(monkeypatch)
    old = _site_figures(name, prof, corners)
    assert len(new) == len(old)
    for a, b in zip(new[:-1], old[:-1]):
        assert a == b
    assert new[-1] is not None and old[-1] is None        # (the compiled reading was taken)


@pytest.mark.parametrize("name,prof", [("prusa_gyroid_fullspeed_klipper.gcode", "voron24"),
                                       ("prusa_gyroid.gcode", "prusa-mk3s")])
def test_law_rows_at_table_index(name, prof, monkeypatch):
    """_LawCols.rows given _table_rows' flat index (and, s62, its rows' spans made for the
    groups at once) answers what its own gather does; so do the binding masks the items
    carry (s63: one gather of the chunk's, item.bnd, in place of _LawCols.rows')."""
    real = chains._table_items
    used = []

    def items(*args, **kw):
        laws = args[17] if len(args) > 17 else kw.get("laws")
        for item in real(*args, **kw):
            n = item[4].shape[1]
            ref = laws.rows(item.j, item[2], n)
            got = laws.rows(item.j, item[2], n, item.at, item.spans)
            for g in (got, (item.bnd,) + ref[1:]) if item.bnd is not None else (got,):
                assert [a.tobytes() for a in g] == [a.tobytes() for a in ref]
                assert [a.dtype for a in g] == [a.dtype for a in ref]
                assert [a.shape for a in g] == [a.shape for a in ref]
            used.append(item.at is not None and item.spans is not None and item.bnd is not None)
            yield item
    monkeypatch.setattr(chains, "_table_items", items)
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    assert any(used)                        # (the shared index and masks were taken)


def test_codes_and_ids_step_aside_where_intp_is_not_a_c_long(monkeypatch):
    # obj_codes / obj_ids refuse an intp buffer that is not 'l' (Windows' numpy: 'q');
    # objfields must then answer None (the callers' own reads) rather than raise
    import builtins
    import importlib
    core = objfields._CORE
    if core is None or objfields._CODES is None:
        pytest.skip("curve core not built")
    with pytest.raises(ValueError):
        core.obj_codes([1, 2], None, {}, True, np.empty(2, np.longlong).view("q"))

    class _Q:
        format = "q"
    real = builtins.memoryview
    monkeypatch.setattr(builtins, "memoryview", lambda o: _Q() if isinstance(o, np.ndarray) else real(o))
    try:
        importlib.reload(objfields)
        assert objfields._CODES is None and objfields._IDS is None
        assert objfields.codes([1, 2], None, {}, add=True) is None
        assert objfields.ids([object()], None) is None
    finally:
        monkeypatch.setattr(builtins, "memoryview", real)
        importlib.reload(objfields)
    assert objfields._CODES is not None


def test_by_identity_is_ids_or_its_python_twin(monkeypatch):
    # by_identity answers everywhere: the core's ids() where it can, else the same objects
    # in the same order and the same places by Python's reads (the four callers' old fallbacks)
    class L:
        pass
    a, b, c = L(), L(), L()

    class S:
        __slots__ = ("lim",)

        def __init__(self, lim):
            self.lim = lim
    objs = [S(x) for x in (a, a, b, a, c, c, b)]
    want_firsts, want_which = [a, b, c], [0, 0, 1, 0, 2, 2, 1]
    for core in (True, False):
        if not core:
            monkeypatch.setattr(objfields, "_IDS", None)
        firsts, which = objfields.by_identity(objs, "lim")
        assert [id(x) for x in firsts] == [id(x) for x in want_firsts]
        assert which.dtype == np.intp and which.tolist() == want_which
        f0, w0 = objfields.by_identity([], "lim")
        assert f0 == [] and w0.dtype == np.intp and w0.size == 0
        with pytest.raises(AttributeError):
            objfields.by_identity([S(a), object()], "lim")
