"""Dataclasses whose methods are not generated source.

@dataclass writes its classes' __init__, __repr__, __eq__ (and, frozen, __hash__,
__setattr__, __delattr__) as source text and compiles it at every import: ~13 M
instructions of each run's start for Profile's 35 fields alone.  @record makes the class a
dataclass all the same (dataclasses.fields, replace, asdict and is_dataclass work on it: it
registers the fields with @dataclass(init=False, repr=False, eq=False), which generates
nothing) and gives it those methods as closures over its fields, with @dataclass's
behaviour: positional or keyword arguments in field order, defaults and default factories,
the repr "Cls(a=1, b='x')", equality of the fields' tuples between instances of the very
same class, and for a frozen record FrozenInstanceError on assignment and a hash of the
fields' tuple (a mutable one is unhashable).  Its __dataclass_params__ show the
registration's flags, not these; the repr has no guard against a record that holds itself.  Only what the package's records use: no __post_init__,
InitVar, init=False field or keyword-only field."""
from __future__ import annotations

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
