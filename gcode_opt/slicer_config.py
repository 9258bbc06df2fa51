"""What the slicer says about the machine: its settings block, Cura's header, SLIC3R_* variables.

PrusaSlicer, SuperSlicer, OrcaSlicer and Bambu Studio end a G-code file with every setting
as a comment (`; machine_max_acceleration_x = 1000,960`).  PrusaSlicer (and its forks)
also hands each setting to a post-processing script as an environment variable named
`SLIC3R_` + the key in upper case, with the same serialised value (ConfigBase::setenv_).
Cura writes `;FLAVOR:Marlin` in its header and, when the GUI saves a file, its changed
settings as `;SETTING_3 {json}` lines at the very end (JSON cut into 80-character pieces).

`read_settings(path)` returns every key found with the place it came from; the file wins
over the environment (the environment may belong to another slicer run), the environment
fills what the file lacks (a file whose comments were stripped)."""
from __future__ import annotations

import os
import re
from .records import field, record
from .words import LazyPattern

HEAD_BYTES = 16384
TAIL_BYTES = 262144          # a PrusaSlicer/Orca config block with long custom G-code is ~50-100 kB

# (the two "^;" patterns are read through _findall_at_line_starts' own; Cura's are
# compiled where a Cura file needs them: LazyPattern)
# A value is the line's text up to its last non-space, `((?:.*\S)?)`: the lazy `(.*?)\s*$`
# it replaces read the same values but tried `\s*$` at every character of the value, so a
# line with a long run of spaces took quadratic time (200 k spaces: ~90 s)
_KEY_VALUE = LazyPattern(globals(), "_KEY_VALUE", r"^;\s*([a-z][a-z0-9_]*)\s*=[ \t]?((?:.*\S)?)\s*$", re.M)
_CURA_FLAVOR = re.compile(r"^;FLAVOR:((?:.*\S)?)\s*$", re.M)
_CURA_SETTING = LazyPattern(globals(), "_CURA_SETTING", r"^;SETTING_3 (.*?)\r?$", re.M)
_CURA_ESCAPE = LazyPattern(globals(), "_CURA_ESCAPE", r"\\\\|\\n|\\r")
_CURA_UNESCAPE = {"\\\\": "\\", "\\n": "\n", "\\r": "\r"}
_CURA_VALUE = LazyPattern(globals(), "_CURA_VALUE", r"^\s*([a-z][a-z0-9_]*)\s*=\s*((?:.*\S)?)\s*$", re.M)


def _findall_at_line_starts(pattern):
    r"""pattern.findall(text) as a function, fast, for a multiline pattern that starts with
    "^;": the same pattern with "\n;" for "^;", run over "\n" + text.  The regex engine has
    no literal to look for in "^;" (its findall tries every position: ~1 ms on a 256 kB
    tail); "\n;" it looks for as a string.  The same matches where no match of the pattern
    ends just after a "\n" (as none of the two below does: a "$" follows whatever they
    consume last): a line starts at the text's first character or just after a "\n", and
    a match never ends where the next one begins, so the "\n" the next one starts with is
    always free."""
    assert pattern.pattern.startswith("^;") and pattern.flags & re.M
    nl = re.compile("\n" + pattern.pattern[1:], pattern.flags)
    return lambda text: nl.findall("\n" + text)


_find_key_values = _findall_at_line_starts(_KEY_VALUE)          # over the tail
_find_cura_settings = _findall_at_line_starts(_CURA_SETTING)


@record
class SlicerSettings:
    """The slicer's own settings a file carries (its comments), raw text by key."""
    values: dict = field(default_factory=dict)     # key -> raw text as the slicer serialised it
    where: dict = field(default_factory=dict)      # key -> "file" | "SLIC3R_KEY" | "Cura ;SETTING_3" | "Cura ;FLAVOR"
    slicer: str = ""                               # "prusaslicer-like", "cura" or ""
    head: str = ""                                 # the file's first lines (Cura's start G-code comments)

    def get(self, key):
        return self.values.get(key)

    def number(self, key):
        """First number of a value ('1000,960' -> 1000.0: normal mode before silent), or None."""
        raw = self.values.get(key)
        if raw is None:
            return None
        first = raw.split(",")[0].strip().rstrip("%")
        try:
            v = float(first)
        except ValueError:
            return None
        return v if v == v and abs(v) != float("inf") else None

    def source(self, key):
        w = self.where.get(key, "")
        return key if w == "file" else f"{w}" if w.startswith("SLIC3R_") else f"{key}, {w}"


def _head_tail(path):
    size = os.path.getsize(path)
    with open(path, "rb") as fh:
        head = fh.read(min(size, HEAD_BYTES))
        fh.seek(max(size - TAIL_BYTES, 0))          # may overlap the head on a small file: harmless
        tail = fh.read()
    dec = lambda b: b.decode("utf-8", "replace").replace("\r\n", "\n")   # noqa: E731
    return dec(head), dec(tail)


def _cura_settings(tail):
    """key -> value of the [values] sections in Cura's ;SETTING_3 block ({} if none or unreadable)."""
    pieces = _find_cura_settings(tail)
    if not pieces:
        return {}
    # GCodeWriter escapes '\\', newline and CR in the JSON before cutting it; undo that in one pass
    joined = _CURA_ESCAPE.sub(lambda m: _CURA_UNESCAPE[m.group(0)], "".join(pieces))
    import json                   # (only Cura's settings block needs it)
    try:
        blob = json.loads(joined, strict=False)
    except ValueError:
        return {}
    texts = []
    if isinstance(blob, dict):
        for v in blob.values():
            texts.extend(v if isinstance(v, list) else [v])
    out = {}
    for text in texts:
        if not isinstance(text, str):
            continue
        section = ""
        for line in text.splitlines():
            s = line.strip()
            if s.startswith("[") and s.endswith("]"):
                section = s[1:-1]
                continue
            m = _CURA_VALUE.match(line)
            if m and section in ("values", "general"):
                out.setdefault(m.group(1), m.group(2))      # global first, extruders after
    return out


def read_settings(path: str, environ=None, metadata=None) -> SlicerSettings:
    """`metadata`: key -> value the caller read elsewhere from the same file (a binary G-code's
    slicer-metadata block); it counts as the file's own, after the text's config block."""
    environ = os.environ if environ is None else environ
    head, tail = _head_tail(path)
    st = SlicerSettings(head=head)
    for key, val in _find_key_values(tail):
        st.values[key] = val                    # the last block wins (it is the file's own)
        st.where[key] = "file"
    for key, val in (metadata or {}).items():
        if key not in st.values:
            st.values[key] = str(val)
            st.where[key] = "file"
    if st.values:
        st.slicer = "prusaslicer-like"
    m = _CURA_FLAVOR.search(head)
    if m:
        st.slicer = st.slicer or "cura"
        st.values.setdefault("cura_flavor", m.group(1))
        st.where.setdefault("cura_flavor", "Cura ;FLAVOR")
    for key, val in _cura_settings(tail).items():
        if key not in st.values:
            st.values[key] = val
            st.where[key] = "Cura ;SETTING_3"
    for name, val in environ.items():
        if name.startswith("SLIC3R_") and not name.startswith("SLIC3R_PP_"):
            key = name[len("SLIC3R_"):].lower()
            if key not in st.values:
                st.values[key] = val
                st.where[key] = name
                st.slicer = st.slicer or "prusaslicer-like"
    return st
