"""Find the re-timed blocks of a processed file and the original lines each replaced.

The emitter fences every re-timed stroke:

    ; gcode-opt begin: replaces N lines, kind=line|curve|arc, K segments, T=...s (was ...s), beta=...s^2
    ...
    ; gcode-opt end

Every line outside a fence is the original's line, copied byte for byte; a fence stands
for N original lines.  Walking the output once therefore pairs each fence with the
original line range it replaced.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..emit import BEGIN, END

_NUM = r"([-+0-9.eE]+|inf|nan)"
_REPLACES = re.compile(r"replaces\s+(\d+)\s+lines")
_SEGMENTS = re.compile(r"(?<!\d)(\d+)\s+segments")     # (?<!\d): from a run's first digit only (linear)
_T = re.compile(r"\bT=" + _NUM + "s")
_WAS = re.compile(r"\(was\s+" + _NUM + "s\\)")
_BETA = re.compile(r"beta=" + _NUM + "s")
_KIND = re.compile(r"\bkind=(\w+)")
_SUBARCS = re.compile(r"(?<!\d)(\d+)\s+sub-arcs")


@dataclass
class Fence:
    out_first: int          # 0-based output line of the begin marker
    out_last: int           # 0-based output line of the end marker
    orig_first: int         # 0-based first original line replaced
    n_orig: int             # original lines replaced
    segments: int           # segments announced by the marker (0 if absent)
    marker_time_s: float    # T= of the marker (nan if absent)
    marker_beta_s2: float   # beta= of the marker (inf for the cubic, nan if absent)
    kind: str | None = None  # kind= of the marker (line, curve, arc); None in older files

    @property
    def orig_last(self) -> int:
        return self.orig_first + self.n_orig - 1


def _num(rx, text, default=math.nan):
    m = rx.search(text)
    if not m:
        return default
    try:
        return float(m.group(1))
    except ValueError:
        return default


def parse_fences(path) -> tuple[list[Fence], int]:
    """Fences of a processed file, and the number of lines the original had."""
    fences = []
    orig = 0
    cur = None
    with open(path, "r", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        for i, raw in enumerate(fh):
            if cur is None:
                if raw.startswith(BEGIN):
                    m = _REPLACES.search(raw)
                    if not m:
                        raise ValueError(f"{path}:{i + 1}: gcode-opt begin marker without 'replaces N lines'")
                    seg = _SEGMENTS.search(raw) or _SUBARCS.search(raw)
                    kind = _KIND.search(raw)
                    cur = Fence(i, -1, orig, int(m.group(1)), int(seg.group(1)) if seg else 0,
                                _num(_T, raw), _num(_BETA, raw), kind.group(1) if kind else None)
                else:
                    orig += 1
            elif raw.startswith(END):
                cur.out_last = i
                fences.append(cur)
                orig += cur.n_orig
                cur = None
    if cur is not None:
        raise ValueError(f"{path}: gcode-opt begin marker at line {cur.out_first + 1} is never closed")
    return fences, orig
