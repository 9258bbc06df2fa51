"""records.record made without importing dataclasses (session 51) against the record it
replaced (OLD, verbatim below: @dataclass(init=False, repr=False, eq=False) at decoration):
the same class bodies give classes that behave the same (construction, errors, repr,
equality, hash, frozen assignment, class attributes, docstring, __match_args__) and the same
dataclasses.fields / __dataclass_params__, registered at the first read; a run's modules
import no dataclasses."""
import dataclasses
import os
import subprocess
import sys
import typing

import pytest

from gcode_opt import detect, profile, records, slicer_config
from gcode_opt.laws import circle, curve

OLD = {}
exec(compile('''from __future__ import annotations

import dataclasses
from dataclasses import MISSING, FrozenInstanceError


def record(cls=None, *, frozen=False):
    """@record or @record(frozen=True) on a class written as for @dataclass."""
    if cls is None:
        return lambda c: _make_record(c, frozen)
    return _make_record(cls, frozen)


def _make_record(cls, frozen):
    cls = dataclasses.dataclass(init=False, repr=False, eq=False)(cls)
    fields = dataclasses.fields(cls)
    if hasattr(cls, "__post_init__") or any(not f.init or f.kw_only for f in fields):
        raise TypeError(f"{cls.__qualname__}: @record does not make this dataclass")
    names = tuple(f.name for f in fields)
    shown = tuple(f.name for f in fields if f.repr)
    compared = tuple(f.name for f in fields if f.compare)
    methods = [_init(cls, fields, frozen), _repr(shown), _eq(compared)]
    if frozen:
        methods += [_hash(tuple(f.name for f in fields if f.hash or (f.hash is None and f.compare))),
                    *_frozen(cls, frozenset(names))]
    else:
        cls.__hash__ = None                 # (@dataclass's eq=True: mutable, so unhashable)
    for fn in methods:
        fn.__qualname__ = f"{cls.__qualname__}.{fn.__name__}"
        setattr(cls, fn.__name__, fn)
    return cls


def _init(cls, fields, frozen):
    """__init__(self, *args, **kwargs): the fields in order, by position then by name."""
    names = tuple(f.name for f in fields)
    index = {n: i for i, n in enumerate(names)}
    defaults = tuple(f.default for f in fields)
    factories = tuple(f.default_factory for f in fields)
    put = object.__setattr__ if frozen else setattr
    where = f"{cls.__qualname__}.__init__()"

    def __init__(self, *args, **kwargs):
        if len(args) > len(names):
            raise TypeError(f"{where} takes {len(names) + 1} positional arguments but "
                            f"{len(args) + 1} were given")
        values = list(args) + [MISSING] * (len(names) - len(args))
        for name, v in kwargs.items():
            i = index.get(name)
            if i is None:
                raise TypeError(f"{where} got an unexpected keyword argument {name!r}")
            if i < len(args):
                raise TypeError(f"{where} got multiple values for argument {name!r}")
            values[i] = v
        for name, v, default, factory in zip(names, values, defaults, factories):
            if v is MISSING:
                if default is not MISSING:
                    v = default
                elif factory is not MISSING:
                    v = factory()
                else:
                    raise TypeError(f"{where} missing 1 required positional argument: {name!r}")
            put(self, name, v)
    return __init__


def _repr(shown):
    def __repr__(self):
        return (self.__class__.__qualname__ + "("
                + ", ".join(f"{n}={getattr(self, n)!r}" for n in shown) + ")")
    return __repr__


def _eq(compared):
    def __eq__(self, other):
        if other.__class__ is self.__class__:
            return (tuple(getattr(self, n) for n in compared)
                    == tuple(getattr(other, n) for n in compared))
        return NotImplemented
    return __eq__


def _hash(hashed):
    def __hash__(self):
        return hash(tuple(getattr(self, n) for n in hashed))
    return __hash__


def _frozen(cls, names):
    def __setattr__(self, name, value):
        if type(self) is cls or name in names:
            raise FrozenInstanceError(f"cannot assign to field {name!r}")
        super(cls, self).__setattr__(name, value)

    def __delattr__(self, name):
        if type(self) is cls or name in names:
            raise FrozenInstanceError(f"cannot delete field {name!r}")
        super(cls, self).__delattr__(name)
    return __setattr__, __delattr__
''', "old_records", "exec"), OLD)

PACKAGE = [profile.Profile, circle.CircleBatch, circle.CircleLaw, curve.CurveLaw, slicer_config.SlicerSettings,
           detect.AutoProfile]


def _bodies(field):
    """Class bodies (a fresh dict each call): defaults, factories by records.field or
    dataclasses.field, flags, no docstring."""
    ann = {"a": "int", "b": "str", "c": "float", "d": "list", "e": "int", "f": "dict"}
    return [
        {"__annotations__": dict(ann), "__doc__": "A record.", "b": "x", "c": 2.5,
         "d": field(default_factory=list), "e": dataclasses.field(default=3, repr=False),
         "f": dataclasses.field(default_factory=dict, compare=False, hash=False),
         "total": lambda self: self.a + self.c},
        {"__annotations__": {"a": "int", "b": "tuple"}, "__module__": __name__, "b": (1, 2)},   # no docstring
        {"__annotations__": {}, "__doc__": "No fields."},
        {"__annotations__": {"a": "int", "h": "int"}, "__doc__": "d", "h": dataclasses.field(default=1, hash=True,
                                                                                             compare=False)},
    ]


def _make(maker, body, frozen):
    return maker(type("Rec", (), body), frozen=frozen)


def _outcome(fn):
    try:
        return ("ok", fn())
    except Exception as e:          # noqa: BLE001 - the kind of error and its text are compared
        return ("raised", type(e), str(e))


CALLS = [((1,), {}), ((1, "y"), {}), ((1, "y", 3.0, [4]), {}), ((), {"a": 1}), ((), {"d": [1], "a": 2}),
         ((1,), {"c": 9.0}), ((), {}), ((1, "y", 3.0, [4], 5, {}, 7), {}), ((1,), {"a": 2}), ((1,), {"zz": 2}),
         ((), {"b": "y"}), ((1, 2), {"h": 5})]


def _class_attrs(cls):
    return {k: v for k, v in vars(cls).items() if not callable(v) and k not in
            ("__dict__", "__weakref__", "__dataclass_fields__", "__dataclass_params__")}


def _fields(cls):
    return [(f.name, f.type, f.default, f.default_factory, f.init, f.repr, f.compare, f.hash, f.kw_only)
            for f in dataclasses.fields(cls)]


@pytest.mark.parametrize("frozen", [False, True])
@pytest.mark.parametrize("which, field", [(0, dataclasses.field), (1, dataclasses.field), (2, dataclasses.field),
                                          (3, dataclasses.field), (0, records.field)])
def test_a_record_behaves_as_the_old_record_of_the_same_body(frozen, which, field):
    bodies = [_bodies(dataclasses.field)[which], _bodies(field)[which]]
    if field is records.field:                   # (records.field has a factory only)
        bodies[0].update(e=3, f=dataclasses.field(default_factory=dict))
        bodies[1].update(e=3, f=records.field(default_factory=dict))
    old = _make(OLD["record"], bodies[0], frozen)
    new = _make(records.record, bodies[1], frozen)
    assert _class_attrs(new) == _class_attrs(old) and new.__doc__ == old.__doc__
    assert new.__match_args__ == old.__match_args__
    assert records.field_names(new) == tuple(f.name for f in dataclasses.fields(old))
    assert _fields(new) == _fields(old) and records.field_names(new) == tuple(f[0] for f in _fields(new))
    assert repr(new.__dataclass_params__) == repr(old.__dataclass_params__)
    assert (new.__hash__ is None) == (old.__hash__ is None)
    for args, kw in CALLS:
        got, want = _outcome(lambda: new(*args, **kw)), _outcome(lambda: old(*args, **kw))
        assert got[0] == want[0], (args, kw)
        if got[0] == "raised":
            assert got[1:] == want[1:]
            continue
        m, o = got[1], want[1]
        assert repr(m) == repr(o) and vars(m) == vars(o)
        assert (m == new(*args, **kw)) and not (m != new(*args, **kw)) and m.__eq__(o) is NotImplemented
        if frozen:
            for act in (lambda x: setattr(x, "a", 5), lambda x: delattr(x, "a"), lambda x: setattr(x, "z", 1)):
                assert _outcome(lambda: act(m)) == _outcome(lambda: act(o))
            if "d" not in vars(m) or not isinstance(m.d, list):
                assert hash(m) == hash(o)
        change = {"a": 9} if "a" in new.__match_args__ else {}
        q, r = dataclasses.replace(m, **change), dataclasses.replace(o, **change)
        assert type(q) is new and repr(q) == repr(r)


def test_the_packages_records_register_at_first_read_only():
    """Before the first read the registration waits in the class; field_names then is
    dataclasses.fields' names, before and after."""
    for cls in PACKAGE:
        names = records.field_names(cls)
        assert names == cls.__match_args__
        assert [f.name for f in dataclasses.fields(cls)] == list(names) == list(records.field_names(cls))
        assert isinstance(cls.__dict__["__dataclass_fields__"], dict)
    later = records.record(type("Later", (), {"__annotations__": {"a": "int"}, "__doc__": "x"}))
    assert isinstance(later.__dict__["__dataclass_fields__"], records._Registration)
    assert dataclasses.is_dataclass(later(1)) and isinstance(later.__dict__["__dataclass_fields__"], dict)


def test_what_record_does_not_make_is_refused_as_before():
    """A mutable default: @dataclass's ValueError; a ClassVar, InitVar or base class:
    TypeError (the old record would have made them otherwise; none is used)."""
    for bad in ({"__annotations__": {"a": "list"}, "__doc__": "x", "a": []},):
        with pytest.raises(ValueError) as new_err:
            records.record(type("Rec", (), dict(bad)))
        with pytest.raises(ValueError) as old_err:
            OLD["record"](type("Rec", (), dict(bad)))
        assert str(new_err.value) == str(old_err.value)
    for bad in ({"__annotations__": {"a": "ClassVar[int]"}, "__doc__": "x", "a": 1},
                {"__annotations__": {"a": typing.ClassVar[int]}, "__doc__": "x", "a": 1},
                {"__annotations__": {"a": dataclasses.InitVar[int]}, "__doc__": "x"},
                {"__annotations__": {"a": "int"}, "__doc__": "x", "__post_init__": lambda self: None},
                {"__annotations__": {"a": "int"}, "__doc__": "x", "a": dataclasses.field(default=0, init=False)},
                {"__annotations__": {"a": "int"}, "__doc__": "x", "a": dataclasses.field(default=0, kw_only=True)}):
        with pytest.raises(TypeError):
            records.record(type("Rec", (), bad))
    with pytest.raises(TypeError):
        records.record(type("Rec", (OLD["record"](type("Base", (), {"__doc__": "x"})),), {"__doc__": "y"}))


def test_a_run_imports_no_dataclasses():
    """The modules of a run and their records (made, compared, copied by field_names) leave
    dataclasses out of sys.modules; asking dataclasses about a record still works."""
    code = ("import sys\n"
            "from gcode_opt import cli, detect, pipeline, profile, slicer_config\n"
            "p = profile.load_profile('prusa-mk3s')\n"
            "q = profile.Profile(**{n: getattr(p, n) for n in profile.field_names(profile.Profile)})\n"
            "assert q == p and hash(q) == hash(p) and slicer_config.SlicerSettings().values == {}\n"
            "assert 'dataclasses' not in sys.modules, 'imported'\n"
            "import dataclasses\n"
            "assert dataclasses.replace(p, max_accel_a=1.0).max_accel_a == 1.0\n"
            "assert len(dataclasses.fields(p)) == 35\n")
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(os.path.abspath(profile.__file__))))
    got = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert got.returncode == 0, got.stderr
