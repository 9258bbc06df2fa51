"""How the report prints a number (the tests use the same functions to check the HTML)."""
from __future__ import annotations

import math

_SUP = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")

UNITS = {"s": "s", "mm2_s3": "mm²/s³", "mm2_s": "mm²/s", "J_s": "J·s", "mm_s": "mm/s", "mm_s2": "mm/s²",
         "mm2_s2": "mm²/s²", "mm": "mm", "count": "", "bytes": "B", "pct": "", "share": "", "s2": "s²", "hz": "/s",
         "um": "µm"}


def sig(v: float, n: int = 4) -> str:
    """n significant digits; powers of ten written ×10ⁿ."""
    if v == 0:
        return "0"
    if not math.isfinite(v):
        return "∞" if v > 0 else ("-∞" if v < 0 else "n/a")
    e = int(math.floor(math.log10(abs(v))))
    if -3 <= e < 6:
        dec = max(n - 1 - e, 0)
        return f"{v:,.{dec}f}"
    m = v / 10 ** e
    return f"{m:.{n - 1}f}×10{str(e).translate(_SUP)}"


def fmt(v, unit: str) -> str:
    """Text of value v in the report's unit code (see UNITS); None is 'n/a'."""
    if v is None:
        return "n/a"
    if unit == "pct":
        return f"{v * 100:+.1f} %"
    if unit == "share":                     # a part of a whole, unsigned
        return f"{v * 100:.1f} %"
    if unit in ("count", "bytes"):
        txt = f"{int(v):,}"
    else:
        txt = sig(float(v))
    u = UNITS.get(unit, unit)
    return f"{txt} {u}" if u else txt
