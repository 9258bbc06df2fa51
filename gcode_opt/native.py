"""The optional compiled cores (setup.py builds them when there is a C compiler): which
one may be used.  A core is used unless GCODE_OPT_PURE_PYTHON asks for pure Python, it is
not built, or it was built from another C source than the one installed beside the
Python code it replaces (a stale build: the SHA-256 the build recorded differs).  The
digest covers the source and the local headers it includes (source_digest; setup.py
records the same).

Hashing the ~0.6 MB of C took ~37 M instructions (~8 ms) at every start.  setup.py now
also records, beside the digest, each covered file's size, mtime, ctime and inode as it
hashed them (SOURCE_STAT: stat_record); a load whose files all still have those keys is
given the recorded digest without hashing (unchanged_since_build).  Any write to a file
sets its ctime anew (and a copy or checkout is another inode): then it hashes, as
before.  CPython trusts a .pyc on its source's mtime and size alone.

An installed wheel holds no C source (pyproject.toml's exclude-package-data): its cores
were built with the Python code beside them, and the installed copies of the sources,
whose stat keys never match the build's, were hashed at every start (~4 ms).  With no
source beside the module there is nothing to check (load)."""
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


_REC_SEP, _KEY_SEP = ";", "|"     # stat_record's separators: no quote or backslash (a -D macro's C string)


def stat_record(source: str) -> str:
    """What setup.py records beside a core's digest: the digest, then for each file it
    covers (the source, then its local headers) the path relative to the source's folder,
    '/'-separated, and the _stat_key() source_digest took before reading it.  The keys are
    source_digest's own (a write after them makes the load hash again)."""
    digest = source_digest(source)
    paths, keys, _ = _DIGESTS[source]
    here = os.path.dirname(source)
    rows = [digest]
    for path, key in zip(paths, keys):
        rel = os.path.relpath(path, here).replace(os.sep, "/")
        rows.append(_KEY_SEP.join([rel] + [str(k) for k in key]))
    return _REC_SEP.join(rows)


def unchanged_since_build(source: str, digest: str, record: str) -> bool:
    """True if record (a core's SOURCE_STAT) was made with this digest, names source first,
    and every file it names still has the stat key it had when the build hashed it."""
    rows = record.split(_REC_SEP) if record else []
    if len(rows) < 2 or rows[0] != digest:
        return False
    here = os.path.dirname(source)
    for n, row in enumerate(rows[1:]):
        rel, *key = row.split(_KEY_SEP)
        path = os.path.normpath(os.path.join(here, rel))
        if n == 0 and path != os.path.normpath(source):
            return False
        try:
            if [str(k) for k in _stat_key(path)] != key:
                return False
        except OSError:
            return False
    return True


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
        digest = mod.SOURCE_SHA256
        if not unchanged_since_build(source, digest, getattr(mod, "SOURCE_STAT", "")):
            try:
                digest = source_digest(source)
            except OSError:          # a header it includes is missing: not what the core was built from
                digest = None
        if digest != mod.SOURCE_SHA256:
            return None, (f"the compiled {what} at {mod.__file__} was built from another "
                          f"{os.path.basename(source)} (pip install . rebuilds it)")
    return mod, ""
