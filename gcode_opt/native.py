"""The optional compiled cores (setup.py builds them when there is a C compiler): which
one may be used.  A core is used unless GCODE_OPT_PURE_PYTHON asks for pure Python, it is
not built, or it was built from another C source than the one installed beside the
Python code it replaces (a stale build: the SHA-256 the build recorded differs).  The
digest covers the source and the local headers it includes (source_digest; setup.py
records the same)."""
from __future__ import annotations

import importlib
import os
import re

try:                          # CPython's own SHA-256: hashlib would load OpenSSL (~3.5 MB resident) for it
    from _sha256 import sha256 as _sha256_new      # 3.11
except ImportError:
    try:
        from _sha2 import sha256 as _sha256_new    # 3.12+
    except ImportError:
        from hashlib import sha256 as _sha256_new

# a local header: #include "name.h" (resolved beside the source, as the compiler does)
_LOCAL_INCLUDE = re.compile(rb'^[ \t]*#[ \t]*include[ \t]+"([^"]+)"', re.M)


def _include_names(text: bytes) -> list:
    """_LOCAL_INCLUDE.findall(text), the same names: the pattern is tried only at the
    starts of the lines whose first character other than a blank is a "#" (a findall
    tries it at every position, ~0.1 G instructions over the cores' sources each
    run, as each core is loaded), and, as findall does, not inside the last match."""
    names, done, p = [], 0, text.find(b"#")
    while p >= 0:
        start = text.rfind(b"\n", 0, p) + 1
        if start >= done and not text[start:p].strip(b" \t"):
            m = _LOCAL_INCLUDE.match(text, start)
            if m is not None:
                names.append(m.group(1))
                done = m.end()
        p = text.find(b"#", p + 1)
    return names


def local_headers(source: str) -> list:
    """The paths of the local headers source includes, in order (one level: the
    headers themselves include only system headers; tests/test_native_headers.py)."""
    with open(source, "rb") as fh:
        names = _include_names(fh.read())
    here = os.path.dirname(source)
    return [os.path.normpath(os.path.join(here, n.decode())) for n in names]


# source -> (its path and its headers', their _stat_key()s, digest): two modules load the
# model's core and two the writer's, so a run would hash ~0.5 MB of C twice
_DIGESTS = {}


def _stat_key(path: str) -> tuple:
    """What changes when a file's bytes may have: any write sets st_ctime_ns anew."""
    st = os.stat(path)
    return st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino


def source_digest(source: str) -> str:
    """SHA-256 of a C source followed by its local headers' bytes (local_headers): what a
    core was built from.  A source with no local header hashes as its bytes alone.  Kept
    for the process while none of the files' _stat_key() changes."""
    got = _DIGESTS.get(source)
    if got is not None:
        try:
            if [_stat_key(p) for p in got[0]] == got[1]:
                return got[2]
        except OSError:
            pass
    paths = [source] + local_headers(source)
    keys = [_stat_key(p) for p in paths]     # before reading: a write after this re-hashes next time
    h = _sha256_new()
    for path in paths:
        with open(path, "rb") as fh:
            h.update(fh.read())
    digest = h.hexdigest()
    _DIGESTS[source] = (paths, keys, digest)
    return digest


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
        try:
            digest = source_digest(source)
        except OSError:          # a header it includes is missing: not what the core was built from
            digest = None
        if digest != mod.SOURCE_SHA256:
            return None, (f"the compiled {what} at {mod.__file__} was built from another "
                          f"{os.path.basename(source)} (pip install . rebuilds it)")
    return mod, ""
