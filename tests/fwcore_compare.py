"""Run the firmware model on both cores and compare what they report, bit for bit.

Every float is compared by its bits (float.hex; NaN by its payload), ints and bools by
value and type: LineRecord fields (in on_line order), Block fields (in on_block order,
every planner.Block slot), SimResult fields.  Used by tests/test_fwcore_*.py."""
from __future__ import annotations

import math
import struct

from gcode_opt import state as st
from gcode_opt.firmware import simulate as sm
from gcode_opt.firmware.planner import Block

BLOCK_FIELDS = Block.__slots__
LINE_FIELDS = sm.LineRecord.__slots__
RES_FIELDS = sm.SimResult.__slots__


def bits(v):
    """A value's identity: floats by their 64 bits, the rest by (type, value)."""
    if type(v) is float:
        return ("f", struct.pack("<d", v))
    if isinstance(v, list):
        return ("l", tuple(bits(x) for x in v))
    return (type(v).__name__, v)


def run(events, profile, core, digest=False):
    """(SimResult bits, [LineRecord bits], [Block bits]) of one pass on `core`; with
    `digest`, each record is kept as a hash of its bits (big files)."""
    lines, blocks = [], []
    keep = hash if digest else (lambda x: x)

    def on_line(r):
        lines.append(keep(tuple(bits(getattr(r, f)) for f in LINE_FIELDS)))

    def on_block(b):
        blocks.append(keep(tuple(bits(getattr(b, f)) for f in BLOCK_FIELDS)))

    old = sm.use_core(core)
    try:
        res = sm.simulate_events(iter(events), profile, on_line, on_block)
    finally:
        sm.use_core(old)
    return tuple(bits(getattr(res, f)) for f in RES_FIELDS), lines, blocks


def first_difference(a, b):
    """None if the two runs are the same bits, else a short description of the first
    difference."""
    names = ("SimResult", "LineRecord", "Block")
    fields = (RES_FIELDS, LINE_FIELDS, BLOCK_FIELDS)
    for name, fs, x, y in zip(names, fields, a, b):
        if name == "SimResult":
            x, y = [x], [y]
        if len(x) != len(y):
            return f"{name}: {len(x)} vs {len(y)} records"
        for i, (rx, ry) in enumerate(zip(x, y)):
            if rx != ry:
                if not isinstance(rx, tuple):
                    return f"{name} {i} differs"
                k = next(j for j in range(len(fs)) if rx[j] != ry[j])
                return f"{name} {i} field {fs[k]}: {rx[k]!r} vs {ry[k]!r}"
    return None


def events_of(path, profile):
    return list(st.events(path, profile))


def finite(x):
    return isinstance(x, float) and math.isfinite(x)
