"""The Cura post-processing script, driven the way Cura drives it (a list of layer chunks),
outside Cura: the output must be gcode-opt's, split back at the same layers."""
import importlib.util
import os
import sys

from gcode_opt.profile import load_profile
from gcode_opt.verify import verify

HERE = os.path.dirname(os.path.abspath(__file__))


def _load():
    spec = importlib.util.spec_from_file_location("GcodeOpt", os.path.join(HERE, "..", "integrations", "cura",
                                                                            "GcodeOpt.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_cura_script_retimes_and_keeps_layers(tmp_path):
    mod = _load()
    src = os.path.join(HERE, "..", "sample_gcode", "cura_box.gcode")
    text = open(src, newline="").read()
    data = mod._split_like(text, 0)                 # what Cura hands over: header + layers
    assert "".join(data) == text and len(data) > 5
    script = mod.GcodeOpt()
    script._settings = {"executable": sys.executable, "profile": "ender3", "max_slowdown": 0.03}
    # run "python -m gcode_opt" as the executable: the script calls [exe, "process", ...]
    exe = tmp_path / "gcode-opt"
    exe.write_text(f"#!/bin/sh\nexec {sys.executable} -m gcode_opt \"$@\"\n")
    exe.chmod(0o755)
    script._settings["executable"] = str(exe)
    out = script.execute(data)
    assert len(out) == len(data)
    assert all(a.split("\n", 1)[0] == b.split("\n", 1)[0] for a, b in zip(data[1:], out[1:]))
    dst = tmp_path / "out.gcode"
    dst.write_text("".join(out))
    res = verify(src, str(dst), load_profile("ender3"))
    assert res["blocks"] > 100
