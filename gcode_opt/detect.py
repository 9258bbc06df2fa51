"""Guess the printer profile from what the slicer wrote into the file.

PrusaSlicer, SuperSlicer, OrcaSlicer and Bambu Studio append their settings as comments
at the end (`; printer_model = MK3S`, `; gcode_flavor = marlin`); Cura writes
`;FLAVOR:Marlin` at the top.  Only the file's head and tail are read."""
from __future__ import annotations

import os
import re

_MODEL = re.compile(r"^;\s*printer_model\s*=\s*(.*)$", re.M)
_FLAVOR = re.compile(r"^;\s*(?:gcode_flavor\s*=\s*|FLAVOR:)(\S*)", re.M)

# printer_model substrings (lower case) -> bundled profile
_MODELS = (("mk3s", "prusa-mk3s"), ("mk3", "prusa-mk3s"), ("mk4", "prusa-mk4"),
           ("x1 carbon", "bambu-x1c"), ("x1c", "bambu-x1c"), ("voron", "voron24"), ("ender-3", "ender3"),
           ("ender3", "ender3"))
_FLAVOURS = (("klipper", "generic-klipper"), ("marlin", "generic-marlin"), ("reprap", "generic-marlin"))


def _head_tail(path, nbytes=65536):
    size = os.path.getsize(path)
    with open(path, "rb") as fh:
        head = fh.read(min(size, 8192))
        fh.seek(max(size - nbytes, 0))
        tail = fh.read()
    return (head + b"\n" + tail).decode("utf-8", "replace")


def detect_profile(path: str) -> tuple[str, str]:
    """(profile name, why).  Falls back to generic-klipper."""
    text = _head_tail(path)
    m = _MODEL.search(text)
    if m and m.group(1).strip():
        model = m.group(1).strip().lower()
        for key, name in _MODELS:
            if key in model:
                return name, f"printer_model = {m.group(1).strip()}"
    m = _FLAVOR.search(text)
    if m:
        fl = m.group(1).strip().lower()
        for key, name in _FLAVOURS:
            if key in fl:
                return name, f"G-code flavour {m.group(1).strip()}"
    return "generic-klipper", "nothing in the file names the printer"
