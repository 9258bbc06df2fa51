"""Dataclasses whose methods are not generated source, made without importing dataclasses.

@dataclass writes its classes' __init__, __repr__, __eq__ (and, frozen, __hash__,
__setattr__, __delattr__) as source text and compiles it at every import: ~13 M
instructions of each run's start for Profile's 35 fields alone.  @record gives the class
those methods as closures over its fields, with @dataclass's behaviour: positional or
keyword arguments in field order, defaults and default factories, the repr
"Cls(a=1, b='x')", equality of the fields' tuples between instances of the very same class,
and for a frozen record FrozenInstanceError on assignment and a hash of the fields' tuple
(a mutable one is unhashable).  The record is a dataclass all the same (dataclasses.fields,
replace, asdict and is_dataclass work on it), registered by @dataclass(init=False,
repr=False, eq=False), which generates nothing, at the first read of its
__dataclass_fields__ or __dataclass_params__ (_Registration): a run that never asks does
not import dataclasses (~5 M instructions, and ~1.5 M for Profile's registration).  Its
__dataclass_params__ show the registration's flags; the repr has no guard against a record
that holds itself.  Only what the package's records use: no __post_init__, InitVar,
ClassVar, init=False field, keyword-only field or base class.  A field's default factory:
records.field(default_factory=f) (or dataclasses.field)."""
from __future__ import annotations

import sys

_MISSING = object()                 # no default / no factory (dataclasses.MISSING's role)
_REGISTERED = ("__dataclass_fields__", "__dataclass_params__")


class _Factory:
    """records.field(default_factory=f): what dataclasses.field(default_factory=f) declares."""
    __slots__ = ("default_factory",)

    def __init__(self, default_factory):
        self.default_factory = default_factory


def field(*, default_factory):
    """A field whose default is default_factory() (new for each instance)."""
    return _Factory(default_factory)


class _Spec:
    """One field as @record reads it: name, default, factory and dataclasses' flags."""
    __slots__ = ("name", "default", "factory", "repr", "compare", "hash", "declared")

    def __init__(self, name, value):
        self.name, self.declared = name, value     # declared: the class attribute, or _MISSING
        self.default, self.factory, self.repr, self.compare, self.hash = value, _MISSING, True, True, None
        if isinstance(value, _Factory):
            self.default, self.factory = _MISSING, value.default_factory
        elif _is_dataclass_field(value):
            missing = sys.modules["dataclasses"].MISSING
            if not value.init or value.kw_only is True:
                raise TypeError(f"field {name!r}: @record makes no init=False or keyword-only field")
            self.default = _MISSING if value.default is missing else value.default
            self.factory = _MISSING if value.default_factory is missing else value.default_factory
            self.repr, self.compare, self.hash = value.repr, value.compare, value.hash
        if self.default is not _MISSING and type(self.default).__hash__ is None:
            raise ValueError(f"mutable default {type(self.default)} for field {name} is not allowed: "
                             "use default_factory")                # (@dataclass's check)


def _is_dataclass_field(value):
    """value is a dataclasses.Field (then dataclasses is imported already)."""
    dc = sys.modules.get("dataclasses")
    return dc is not None and isinstance(value, dc.Field)


def _specs(cls):
    """The fields of cls's body, in order; the declarations that are not defaults (factories,
    dataclasses.Field) leave the class, as @dataclass removes them."""
    if cls.__bases__ != (object,) or hasattr(cls, "__post_init__"):
        raise TypeError(f"{cls.__qualname__}: @record does not make this dataclass")
    specs = []
    for name, kind in cls.__dict__.get("__annotations__", {}).items():
        if "ClassVar" in str(kind) or "InitVar" in str(kind):
            raise TypeError(f"{cls.__qualname__}.{name}: @record makes no ClassVar or InitVar field")
        s = _Spec(name, cls.__dict__.get(name, _MISSING))
        if s.declared is not _MISSING and s.default is not s.declared:
            if s.default is _MISSING:
                delattr(cls, name)
            else:
                setattr(cls, name, s.default)
        specs.append(s)
    return specs


class _Registration:
    """__dataclass_fields__ / __dataclass_params__ of a record until first read: the read
    registers the record with @dataclass(init=False, repr=False, eq=False) (its
    declarations put back for it to read) and gives what that set."""

    def __init__(self, cls, name, specs):
        self.cls, self.name, self.specs = cls, name, specs

    def __get__(self, obj, owner=None):
        _register(self.cls, self.specs)
        return self.cls.__dict__[self.name]


def _register(cls, specs):
    import dataclasses
    for name in _REGISTERED:
        if isinstance(cls.__dict__.get(name), _Registration):
            delattr(cls, name)
    for s in specs:
        if s.declared is not _MISSING and s.default is not s.declared:
            setattr(cls, s.name, s.declared if _is_dataclass_field(s.declared)
                    else dataclasses.field(default_factory=s.factory))
    dataclasses.dataclass(init=False, repr=False, eq=False)(cls)


def field_names(cls):
    """The names of a record's fields, in order (dataclasses.fields' names, without the
    registration)."""
    got = cls.__dict__.get("__dataclass_fields__")
    if isinstance(got, _Registration):
        return tuple(s.name for s in got.specs)
    import dataclasses
    return tuple(f.name for f in dataclasses.fields(cls))


def record(cls=None, *, frozen=False):
    """@record or @record(frozen=True) on a class written as for @dataclass."""
    if cls is None:
        return lambda c: _make_record(c, frozen)
    return _make_record(cls, frozen)


def _make_record(cls, frozen):
    specs = _specs(cls)
    names = tuple(f.name for f in specs)
    if "__match_args__" not in cls.__dict__:
        cls.__match_args__ = names
    if cls.__doc__:
        for name in _REGISTERED:
            setattr(cls, name, _Registration(cls, name, specs))
    else:                                   # (@dataclass writes the docstring from the signature)
        _register(cls, specs)
    shown = tuple(f.name for f in specs if f.repr)
    compared = tuple(f.name for f in specs if f.compare)
    methods = [_init(cls, specs, frozen), _repr(shown), _eq(compared)]
    if frozen:
        methods += [_hash(tuple(f.name for f in specs if f.hash or (f.hash is None and f.compare))),
                    *_frozen(cls, frozenset(names))]
    else:
        cls.__hash__ = None                 # (@dataclass's eq=True: mutable, so unhashable)
    for fn in methods:
        fn.__qualname__ = f"{cls.__qualname__}.{fn.__name__}"
        setattr(cls, fn.__name__, fn)
    return cls


def _init(cls, specs, frozen):
    """__init__(self, *args, **kwargs): the fields in order, by position then by name."""
    names = tuple(f.name for f in specs)
    index = {n: i for i, n in enumerate(names)}
    defaults = tuple(f.default for f in specs)
    factories = tuple(f.factory for f in specs)
    put = object.__setattr__ if frozen else setattr
    where = f"{cls.__qualname__}.__init__()"

    def __init__(self, *args, **kwargs):
        if len(args) > len(names):
            raise TypeError(f"{where} takes {len(names) + 1} positional arguments but "
                            f"{len(args) + 1} were given")
        values = list(args) + [_MISSING] * (len(names) - len(args))
        for name, v in kwargs.items():
            i = index.get(name)
            if i is None:
                raise TypeError(f"{where} got an unexpected keyword argument {name!r}")
            if i < len(args):
                raise TypeError(f"{where} got multiple values for argument {name!r}")
            values[i] = v
        for name, v, default, factory in zip(names, values, defaults, factories):
            if v is _MISSING:
                if default is not _MISSING:
                    v = default
                elif factory is not _MISSING:
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
            raise _frozen_error(f"cannot assign to field {name!r}")
        super(cls, self).__setattr__(name, value)

    def __delattr__(self, name):
        if type(self) is cls or name in names:
            raise _frozen_error(f"cannot delete field {name!r}")
        super(cls, self).__delattr__(name)
    return __setattr__, __delattr__


def _frozen_error(text):
    """dataclasses.FrozenInstanceError(text) (dataclasses imported when one is raised)."""
    from dataclasses import FrozenInstanceError
    return FrozenInstanceError(text)
