"""The command run in-process on the list path or windowed (GCODE_OPT_WINDOWED, `window`
strokes a window): the bytes it wrote and its summary without the volatile keys, what the
windowed tests compare with the list path's."""
import json

from gcode_opt import pipeline as pl
from gcode_opt.profile import load_profile

VOLATILE = ("timing_s", "elapsed_s", "output")


def run_command(monkeypatch, src, out, windowed, window, profile="prusa-mk3s"):
    """(bytes written to out, summary) of process(src -> out) on the path asked."""
    if windowed:
        monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
        monkeypatch.setenv("GCODE_OPT_WINDOW", str(window))
    else:
        monkeypatch.delenv("GCODE_OPT_WINDOWED", raising=False)
    s = pl.process(str(src), str(out), load_profile(profile), pl.Options())
    s = json.loads(json.dumps({k: v for k, v in s.items() if k not in VOLATILE}, default=str))
    return out.read_bytes(), s
