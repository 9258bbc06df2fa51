"""records.record against @dataclass itself: the same class body made both ways behaves the
same (construction by position and name, defaults and factories, the errors, repr, equality,
hash, frozen assignment, dataclasses.fields / replace / asdict / __match_args__), and the
package's records are such classes with no generated source."""
import dataclasses

import numpy as np
import pytest

from gcode_opt import detect, profile, records, slicer_config
from gcode_opt.laws import circle, curve

RECORDS = [(profile.Profile, True), (circle.CircleBatch, False), (circle.CircleLaw, False),
           (curve.CurveLaw, False), (slicer_config.SlicerSettings, False), (detect.AutoProfile, False)]


def _body():
    return {"__annotations__": {"a": "int", "b": "str", "c": "float", "d": "list"},
            "__doc__": "A record.", "b": "x", "c": 2.5, "d": dataclasses.field(default_factory=list),
            "total": lambda self: self.a + self.c}


def _pair(frozen):
    mine = records.record(type("Rec", (), _body()), frozen=frozen)
    ref = dataclasses.dataclass(type("Rec", (), _body()), frozen=frozen)
    return mine, ref


def _outcome(fn):
    try:
        return ("ok", fn())
    except Exception as e:          # noqa: BLE001 - the kind of error is what is compared
        return ("raised", type(e))


CALLS = [((1,), {}), ((1, "y"), {}), ((1, "y", 3.0, [4]), {}), ((), {"a": 1}), ((), {"d": [1], "a": 2}),
         ((1,), {"c": 9.0}), ((), {}), ((1, "y", 3.0, [4], 5), {}), ((1,), {"a": 2}), ((1,), {"zz": 2}),
         ((), {"b": "y"})]


@pytest.mark.parametrize("frozen", [False, True])
def test_a_record_behaves_as_the_dataclass_of_the_same_body(frozen):
    mine, ref = _pair(frozen)
    assert dataclasses.is_dataclass(mine)
    assert [(f.name, f.type, f.default, f.default_factory) for f in dataclasses.fields(mine)] == \
        [(f.name, f.type, f.default, f.default_factory) for f in dataclasses.fields(ref)]
    assert mine.__match_args__ == ref.__match_args__ and mine.__doc__ == ref.__doc__
    made = []
    for args, kw in CALLS:
        got, want = _outcome(lambda: mine(*args, **kw)), _outcome(lambda: ref(*args, **kw))
        assert got[0] == want[0], (args, kw)
        if got[0] == "raised":
            assert got[1] is want[1] is TypeError
            continue
        m, r = got[1], want[1]
        assert repr(m) == repr(r) and vars(m) == vars(r) and m.total() == r.total()
        made.append((m, r))
    assert made[0][0].d is not mine(1).d                     # a factory's value is new each time
    for m1, r1 in made:
        for m2, r2 in made:
            assert (m1 == m2) == (r1 == r2) and (m1 != m2) == (r1 != r2)
        assert (m1 == r1) is False and m1.__eq__(5) is NotImplemented
        if frozen:
            h = dataclasses.replace(m1, d=tuple(m1.d))       # (a list field: unhashable either way)
            assert hash(h) == hash(dataclasses.replace(r1, d=tuple(r1.d)))
            for act in (lambda: setattr(m1, "a", 5), lambda: delattr(m1, "a"), lambda: setattr(m1, "new", 1)):
                assert _outcome(act) == ("raised", dataclasses.FrozenInstanceError)
        else:
            assert mine.__hash__ is None and ref.__hash__ is None
            m1.a, r1.a = 7, 7
            assert repr(m1) == repr(r1)
        q = dataclasses.replace(m1, b="z")
        assert type(q) is mine and dataclasses.asdict(q) == dataclasses.asdict(dataclasses.replace(r1, b="z"))


def test_a_record_subclass_of_a_frozen_record_may_set_its_own_attributes():
    mine, ref = _pair(True)
    sub_m, sub_r = type("Sub", (mine,), {}), type("Sub", (ref,), {})
    for cls in (sub_m, sub_r):
        x = cls(1)
        x.extra = 3                 # (not a field, not the record's own class)
        assert x.extra == 3
        assert _outcome(lambda: setattr(x, "a", 2)) == ("raised", dataclasses.FrozenInstanceError)


def test_what_record_does_not_make_is_refused():
    for extra in ({"__post_init__": lambda self: None},
                  {"e": dataclasses.field(default=0, init=False)}):
        body = _body()
        body.update(extra)
        if "e" in extra:
            body["__annotations__"] = {**body["__annotations__"], "e": "int"}
        with pytest.raises(TypeError):
            records.record(type("Rec", (), body))


def _twin(cls, frozen):
    """cls's fields made a plain @dataclass: the reference of the package's records."""
    specs = [(f.name, f.type, dataclasses.field(default=f.default, default_factory=f.default_factory))
             for f in dataclasses.fields(cls)]
    return dataclasses.make_dataclass(cls.__name__, specs, frozen=frozen)


def test_the_packages_records_match_their_dataclass_twins_and_have_no_generated_source():
    p = profile.load_profile("prusa-mk3s")
    values = {"Profile": vars(p), "SlicerSettings": {"values": {"a": "1"}, "slicer": "cura"},
              "AutoProfile": {"profile": p, "base": "b", "why_base": "w", "taken": {}, "notes": []},
              "CircleLaw": {"batch": None, "i": 3},
              "CurveLaw": dict(S=1.0, T=2.0, beta=0.1, kappa=None, dkappa=None, coef=None, cc=0.5, n=4),
              "CircleBatch": {n: None for n in ("phi_total", "T_t", "beta_s2", "w0", "w1", "R_d", "regime",
                                                "wc", "cc", "coef")}}
    for cls, frozen in RECORDS:
        for name in ("__init__", "__repr__", "__eq__", "__hash__", "__setattr__"):
            fn = cls.__dict__.get(name)
            code = getattr(fn, "__code__", None)
            assert code is None or code.co_filename == records.__file__, (cls, name)
        twin = _twin(cls, frozen)
        kw = values[cls.__name__]
        a, b = cls(**kw), twin(**kw)
        assert repr(a) == repr(b) and vars(a) == vars(b)
        assert (a == cls(**kw)) and not (a != cls(**kw))
        assert (cls.__hash__ is None) == (twin.__hash__ is None)
        if frozen:
            assert hash(a) == hash(b)
    batch = circle.CircleBatch(*[np.arange(3.0)] * 10)
    assert batch.grid_levels is None and batch.take(np.array([0, 2])).phi_total.tolist() == [0.0, 2.0]
