"""Cura post-processing script: runs gcode-opt on the sliced G-code.

Install: copy this file into Cura's `scripts` folder (Help > Show Configuration Folder,
then `scripts/`), restart Cura, and add "gcode-opt" under Extensions > Post Processing >
Modify G-Code.  gcode-opt itself must be installed (`pip install .` in a venv); give the
full path of its `gcode-opt` executable in the script's settings.

Cura hands scripts a list: the header, the start G-code, one item per layer, the end
G-code (CuraEngine flushes its output once before each layer it writes and once at the end;
Cura inserts the header in front).  Later scripts rely on those positions, so the list goes
back with the same length: every item that is not a layer exactly as given, and each
re-timed block in the layer item whose lines it replaced.  gcode-opt marks each block
`; gcode-opt begin: replaces N lines, ...` / `; gcode-opt end`, and leaves every line outside
a block as it was: that is how the blocks are put back in place.

When gcode-opt fails, the G-code goes on unprocessed and Cura shows why in a message
(a script's exception would only reach Cura's log)."""
import json
import os
import re
import subprocess
import tempfile

try:
    from ..Script import Script          # inside Cura's PostProcessingPlugin
except (ImportError, ValueError):        # pragma: no cover - outside Cura
    class Script:
        def getSettingValueByKey(self, key):
            return self._settings[key]

_BEGIN = re.compile(r"^; gcode-opt begin: replaces (\d+) lines")
_END = "; gcode-opt end"
TITLE = "gcode-opt"


def _tell_user(text, error=True):
    """A message in Cura's window (UM.Message), and the log; outside Cura, nothing."""
    try:
        from UM.Logger import Logger
        Logger.log("e" if error else "w", f"{TITLE}: {text}")
    except ImportError:
        pass
    try:
        from UM.Message import Message
    except ImportError:
        return
    kinds = getattr(Message, "MessageType", None)          # Uranium >= 4.10; older ones have no types
    kind = getattr(kinds, "ERROR" if error else "WARNING", None) if kinds else None
    extra = {"message_type": kind} if kind is not None else {}
    Message(text=text, title=TITLE, lifetime=0, **extra).show()


class GcodeOpt(Script):
    def getSettingDataString(self):
        return json.dumps({
            "name": "gcode-opt (energy/inertia-optimal re-timing)",
            "key": "GcodeOpt",
            "metadata": {},
            "version": 2,
            "settings": {
                "executable": {"label": "gcode-opt executable", "description": "Full path of gcode-opt",
                               "type": "str", "default_value": "gcode-opt"},
                "profile": {"label": "Printer profile", "description": "gcode-opt profile name or .toml path",
                            "type": "str", "default_value": "auto"},
                "max_slowdown": {"label": "Print-time budget", "description": "fraction of the print time",
                                 "type": "float", "default_value": 0.03},
            },
        })

    def execute(self, data):
        exe = self.getSettingValueByKey("executable")
        profile = self.getSettingValueByKey("profile")
        budget = self.getSettingValueByKey("max_slowdown")
        fd, path = tempfile.mkstemp(suffix=".gcode")
        try:
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
                fh.write("".join(data))
            try:
                proc = subprocess.run([exe, "process", "--profile", str(profile), "--max-slowdown", str(budget),
                                       "-q", path], capture_output=True, text=True, encoding="utf-8",
                                      errors="replace", creationflags=getattr(subprocess, "CREATE_NO_WINDOW", 0))
            except OSError as e:
                _tell_user(f"could not start {exe!r} ({e.strerror or e}); set the full path of gcode-opt in the "
                           "script's settings. The G-code was not re-timed.")
                return data
            if proc.returncode != 0:
                why = "\n".join(proc.stderr.strip().splitlines()[-6:]) or f"exit status {proc.returncode}"
                _tell_user(f"gcode-opt failed; the G-code was not re-timed.\n{why}")
                return data
            if proc.stderr.strip():                 # under -q: warnings only (a profile at odds with the file)
                _tell_user(proc.stderr.strip(), error=False)
            with open(path, encoding="utf-8", newline="") as fh:
                text = fh.read()
        finally:
            try:
                os.unlink(path)
            except OSError:
                pass
        try:
            out, reverted = put_back(data, text)
        except ValueError as e:
            _tell_user(f"gcode-opt's output could not be matched to Cura's layers ({e}); "
                       "the G-code was not re-timed.")
            return data
        if reverted:
            _tell_user(f"{reverted} re-timed block(s) crossed a layer boundary or touched the start/end "
                       "G-code and were left as sliced.", error=False)
        return out


def _lines(text):
    """Lines with their ends, cut at '\n' only (as gcode-opt counts them; str.splitlines also cuts
    at form feeds and other separators a comment may hold)."""
    parts = text.split("\n")
    lines = [p + "\n" for p in parts[:-1]]
    return lines + [parts[-1]] if parts[-1] else lines


def _is_layer(item):
    """A layer item holds a ';LAYER:n' line; the header, start and end G-code do not."""
    return any(line.startswith(";LAYER:") for line in _lines(item))


def put_back(data, text):
    """Cura's list `data` with gcode-opt's output `text` (the joined list, re-timed) put back
    into the same items: (new list, number of blocks left as sliced).  A block goes into the
    layer item holding all the lines it replaced; one that spans items, or lands in a
    non-layer item, is replaced by its original lines (each block is a drop-in replacement).
    ValueError if a line outside the blocks differs from the input."""
    item_lines = [_lines(item) for item in data]
    owner = [i for i, lines in enumerate(item_lines) for _ in lines]     # input line -> item index
    src = [line for lines in item_lines for line in lines]
    layer = [_is_layer(item) for item in data]
    out = [[] for _ in data]
    out_lines = _lines(text)
    k = 0                                   # next input line
    j = 0
    reverted = 0
    while j < len(out_lines):
        line = out_lines[j]
        m = _BEGIN.match(line)
        if m:
            n = int(m.group(1))
            end = j + 1
            while end < len(out_lines) and not out_lines[end].startswith(_END):
                end += 1
            if end == len(out_lines) or k + n > len(src) or n < 1:
                raise ValueError(f"unterminated or oversized block at output line {j + 1}")
            block = out_lines[j:end + 1]
            if not block[-1].endswith("\n") and end + 1 < len(out_lines):
                raise ValueError(f"block end without a newline at output line {end + 1}")
            items = {owner[i] for i in range(k, k + n)}
            first = owner[k]
            if len(items) == 1 and layer[first]:
                out[first].extend(block)
            else:
                for i in range(k, k + n):
                    out[owner[i]].append(src[i])
                reverted += 1
            k += n
            j = end + 1
            continue
        if k >= len(src) or line != src[k]:
            raise ValueError(f"output line {j + 1} is not input line {k + 1}")
        out[owner[k]].append(line)
        k += 1
        j += 1
    if k != len(src):
        raise ValueError(f"output ends at input line {k} of {len(src)}")
    new = ["".join(lines) for lines in out]
    for i, (old, got) in enumerate(zip(data, new)):
        if not layer[i] and old != got:             # cannot happen by construction; never hand it on
            raise ValueError(f"item {i} (not a layer) would change")
    return new, reverted
