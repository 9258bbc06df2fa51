"""The optional compiled cores (setup.py builds them when there is a C compiler): which
one may be used.  A core is used unless GCODE_OPT_PURE_PYTHON asks for pure Python, it is
not built, or it was built from another C source than the one installed beside the
Python code it replaces (a stale build: the SHA-256 the build recorded differs)."""
from __future__ import annotations

import hashlib
import importlib
import os


def pure_python_asked() -> bool:
    return os.environ.get("GCODE_OPT_PURE_PYTHON", "") not in ("", "0")


def load(module: str, source: str, what: str):
    """(the module, "") or (None, why not).  module: the extension's name; source: the C
    file it must have been built from; what: its name in the reason ("core", "reader")."""
    if pure_python_asked():
        return None, "GCODE_OPT_PURE_PYTHON is set"
    try:
        mod = importlib.import_module(module)
    except ImportError:
        return None, f"the compiled {what} is not built (pip install . with a C compiler builds it)"
    if os.path.exists(source):
        with open(source, "rb") as fh:
            if hashlib.sha256(fh.read()).hexdigest() != mod.SOURCE_SHA256:
                return None, (f"the compiled {what} at {mod.__file__} was built from another "
                              f"{os.path.basename(source)} (pip install . rebuilds it)")
    return mod, ""
