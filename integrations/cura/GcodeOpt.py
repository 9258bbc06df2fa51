"""Cura post-processing script: runs gcode-opt on the sliced G-code.

Install: copy this file into Cura's `scripts` folder (Help > Show Configuration Folder,
then `scripts/`), restart Cura, and add "gcode-opt" under Extensions > Post Processing >
Modify G-Code.  gcode-opt itself must be installed (`pip install .` in a venv); give the
full path of its `gcode-opt` executable in the script's settings.

Cura hands scripts the G-code as a list of chunks (a header, then one chunk per layer).
The script joins them, lets gcode-opt re-time the file in place, and splits the result
back at the same layer markers, so later scripts see the structure they expect.
"""
import json
import os
import subprocess
import tempfile

try:
    from ..Script import Script          # inside Cura's PostProcessingPlugin
except (ImportError, ValueError):        # pragma: no cover - outside Cura
    class Script:
        def getSettingValueByKey(self, key):
            return self._settings[key]


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
            with os.fdopen(fd, "w", newline="") as fh:
                fh.write("".join(data))
            subprocess.run([exe, "process", "--profile", str(profile), "--max-slowdown", str(budget), "-q", path],
                           check=True, capture_output=True, text=True)
            with open(path, newline="") as fh:
                text = fh.read()
        finally:
            os.unlink(path)
        return _split_like(text, len(data))


def _split_like(text, n_chunks):
    """Split at ';LAYER:' lines as Cura does: header first, then one chunk per layer."""
    chunks, cur = [], []
    for line in text.splitlines(keepends=True):
        if line.startswith(";LAYER:") and cur:
            chunks.append("".join(cur))
            cur = []
        cur.append(line)
    chunks.append("".join(cur))
    return chunks
