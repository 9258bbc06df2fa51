"""Slicer feature comments -> one canonical feature name.

Each slicer names its extrusion roles differently; the planner selects strokes by the
canonical names below (`--features sparse_infill,solid_infill`)."""
from __future__ import annotations

import re

SPARSE_INFILL = "sparse_infill"
SOLID_INFILL = "solid_infill"
TOP_SOLID_INFILL = "top_solid_infill"
BRIDGE_INFILL = "bridge_infill"
PERIMETER = "perimeter"
EXTERNAL_PERIMETER = "external_perimeter"
OVERHANG_PERIMETER = "overhang_perimeter"
GAP_FILL = "gap_fill"
SKIRT = "skirt"
SUPPORT = "support"
SUPPORT_INTERFACE = "support_interface"
IRONING = "ironing"
WIPE_TOWER = "wipe_tower"
CUSTOM = "custom"
TRAVEL = "travel"          # any XY move without extrusion, whatever the comment says
OTHER = "other"

ALL = (SPARSE_INFILL, SOLID_INFILL, TOP_SOLID_INFILL, BRIDGE_INFILL, PERIMETER,
       EXTERNAL_PERIMETER, OVERHANG_PERIMETER, GAP_FILL, SKIRT, SUPPORT, SUPPORT_INTERFACE,
       IRONING, WIPE_TOWER, CUSTOM, TRAVEL, OTHER)
DEFAULT_SELECTED = (SPARSE_INFILL, SOLID_INFILL)

# lower-cased slicer names -> canonical.  PrusaSlicer/SuperSlicer ";TYPE:", OrcaSlicer and
# Bambu Studio ";TYPE:" and "; FEATURE:", Cura ";TYPE:", Simplify3D "; feature ".
_NAMES = {
    # PrusaSlicer / SuperSlicer
    "internal infill": SPARSE_INFILL, "solid infill": SOLID_INFILL,
    "top solid infill": TOP_SOLID_INFILL, "bridge infill": BRIDGE_INFILL,
    "internal bridge infill": BRIDGE_INFILL, "perimeter": PERIMETER,
    "external perimeter": EXTERNAL_PERIMETER, "overhang perimeter": OVERHANG_PERIMETER,
    "gap fill": GAP_FILL, "skirt": SKIRT, "skirt/brim": SKIRT, "brim": SKIRT,
    "support material": SUPPORT, "support material interface": SUPPORT_INTERFACE,
    "ironing": IRONING, "wipe tower": WIPE_TOWER, "custom": CUSTOM,
    # OrcaSlicer / Bambu Studio
    "sparse infill": SPARSE_INFILL, "internal solid infill": SOLID_INFILL,
    "bottom surface": SOLID_INFILL, "top surface": TOP_SOLID_INFILL, "bridge": BRIDGE_INFILL,
    "outer wall": EXTERNAL_PERIMETER, "inner wall": PERIMETER, "overhang wall": OVERHANG_PERIMETER,
    "gap infill": GAP_FILL, "support": SUPPORT, "support interface": SUPPORT_INTERFACE,
    "support transition": SUPPORT, "prime tower": WIPE_TOWER,
    # Cura
    "fill": SPARSE_INFILL, "skin": SOLID_INFILL, "wall-outer": EXTERNAL_PERIMETER,
    "wall-inner": PERIMETER, "support-interface": SUPPORT_INTERFACE, "prime-tower": WIPE_TOWER,
    # Simplify3D
    "infill": SPARSE_INFILL, "solid layer": SOLID_INFILL, "outer perimeter": EXTERNAL_PERIMETER,
    "inner perimeter": PERIMETER, "gap fill ": GAP_FILL,
}

_PREFIXES = (";type:", "; feature:", ";feature:", "; feature ")
_LAYER_MARKERS = (";layer_change", ";layer:", "; change_layer", ";layer_change")


def feature_from_comment(comment: str) -> str | None:
    """Canonical feature named by a comment line, or None if the comment names none."""
    c = comment.strip().lower()
    for p in _PREFIXES:
        if c.startswith(p):
            name = c[len(p):].strip()
            return _NAMES.get(name, OTHER)
    return None


def is_layer_change(comment: str) -> bool:
    c = comment.strip().lower()
    return c.startswith(_LAYER_MARKERS)


def parse_feature_list(text: str) -> tuple[str, ...]:
    """'sparse_infill,solid_infill' -> tuple; 'all' -> every feature. Raises ValueError."""
    if text.strip().lower() == "all":
        return ALL
    out = tuple(t.strip().lower().replace("-", "_").replace(" ", "_") for t in text.split(",") if t.strip())
    bad = [t for t in out if t not in ALL]
    if bad:
        raise ValueError(f"unknown feature(s) {', '.join(bad)}; choose from {', '.join(ALL)}")
    return out


# What a file without feature comments re-times by default (issue 9 item 4): every extruding
# move is `other` there (state.py's start value), so `other` selects all extrusion --
# infill, perimeters and skirt alike -- and never travel.  Measured (firmware model, default
# options, README "Files without feature comments"): this beats both doing nothing (0 %) and
# classify.py's open runs; zero overshoot instead re-times almost nothing.
NO_COMMENTS_SELECTED = (OTHER,)
NO_COMMENTS_WHY = ("no feature comments in the file: re-timing every extruding move (perimeters and skirt "
                   "included, never travel), the default for such files; --features chooses otherwise")

# a full-line comment that feature_from_comment() reads as a feature (any case)
_FEATURE_LINE_B = re.compile(rb"^[ \t]*(?:;type:|; ?feature:|; feature )", re.IGNORECASE | re.MULTILINE)


def has_feature_comments(path, chunk_b: int = 1 << 22) -> bool:
    """True if any line of the file is a slicer feature comment (what analyse's `seen` flag
    would find), read in 4 MB chunks; stops at the first (near the top in a sliced file)."""
    tail = b""
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(chunk_b), b""):
            buf = tail + chunk
            if _FEATURE_LINE_B.search(buf):
                return True
            cut = buf.rfind(b"\n")                   # keep the last partial line for the next chunk
            tail = buf[cut + 1:] if cut >= 0 else buf[-256:]
    return False


def default_selection(path):
    """(features, why) the CLI uses when --features is not given: the slicer's infill where
    the file names its features, all extrusion where it names none (why says so; else None)."""
    if has_feature_comments(path):
        return DEFAULT_SELECTED, None
    return NO_COMMENTS_SELECTED, NO_COMMENTS_WHY


def selection_info(comments_seen: bool, selected) -> dict:
    """What the feature selection could act on (summary["features"]): without any feature
    comment every extruding move is `other` (state.py's start value), so a selection
    that does not name `other` re-times no extrusion -- say so."""
    selected = tuple(selected)
    info = {"source": "comments" if comments_seen else "none", "selected": list(selected)}
    if not comments_seen and OTHER not in selected:
        info["note"] = ("no feature comments in the file, so every extruding move is 'other', which is "
                        "not selected: no extrusion is re-timed (--features all re-times every move)")
    return info
