"""The Cura post-processing script, driven the way Cura drives it, outside Cura.

The list is built here the way Cura builds it, not with the script's own code:
CuraEngineBackend._onGCodeLayerMessage appends each GCodeLayer message and
_onGCodePrefixMessage inserts the header at position 0 (Cura plugins/CuraEngineBackend/
CuraEngineBackend.py).  CuraEngine flushes its G-code as one message each time
LayerPlanBuffer::processBuffer hands a layer over to be written (so everything written before
layer 0 -- the start G-code -- is one message) and once more at the end of the mesh group
(LayerPlanBuffer::flush, then Scene::processMeshGroup after finalize(): the end G-code).
A layer's text starts with its ';LAYER:n' comment and ends with its ';TIME_ELAPSED:' comment.
So a CuraEngine file cuts into: header (up to ';Generated with Cura_SteamEngine ...'),
start G-code, one item per layer, end G-code."""
import importlib.util
import os
import subprocess
import sys
import types

import pytest

from gcode_opt.profile import load_profile
from gcode_opt.verify import verify

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.join(HERE, "..", "sample_gcode", "cura_box.gcode")


def _load():
    spec = importlib.util.spec_from_file_location("GcodeOpt", os.path.join(HERE, "..", "integrations", "cura",
                                                                            "GcodeOpt.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def cura_gcode_list(text):
    """[header, start G-code, layer 0, ..., layer n, end G-code] cut at CuraEngine's flush points."""
    gen = text.index(";Generated with Cura_SteamEngine")
    cuts = [text.index("\n", gen) + 1]                       # header = the prefix message
    pos = text.find("\n;LAYER:", cuts[0])
    while pos != -1:                                          # each layer message starts at ;LAYER:n
        cuts.append(pos + 1)
        pos = text.find("\n;LAYER:", pos + 1)
    last = text.rindex("\n;TIME_ELAPSED:")                    # the last layer ends with its time comment
    cuts.append(text.index("\n", last + 1) + 1)
    bounds = [0] + cuts + [len(text)]
    return [text[a:b] for a, b in zip(bounds, bounds[1:])]


def _exe(tmp_path, body=None):
    """An executable the script can call as `exe process ...`: gcode-opt itself, or a stand-in."""
    exe = tmp_path / "gcode-opt"
    exe.write_text(body or f"#!/bin/sh\nexec {sys.executable} -m gcode_opt \"$@\"\n")
    exe.chmod(0o755)
    return str(exe)


@pytest.fixture
def shown(monkeypatch):
    """Stand-ins for Uranium's Message and Logger: what the script shows the user."""
    msgs = []

    class Message:
        class MessageType:
            ERROR, WARNING, NEUTRAL = "error", "warning", "neutral"

        def __init__(self, text="", lifetime=30, title=None, message_type=None, **kw):
            self.text, self.title, self.kind = text, title, message_type

        def show(self):
            msgs.append(self)

    class Logger:
        @staticmethod
        def log(level, text):
            pass

    um = types.ModuleType("UM")
    m1, m2 = types.ModuleType("UM.Message"), types.ModuleType("UM.Logger")
    m1.Message, m2.Logger = Message, Logger
    monkeypatch.setitem(sys.modules, "UM", um)
    monkeypatch.setitem(sys.modules, "UM.Message", m1)
    monkeypatch.setitem(sys.modules, "UM.Logger", m2)
    return msgs


def test_list_is_built_like_cura():
    text = open(SRC, newline="").read()
    data = cura_gcode_list(text)
    assert "".join(data) == text
    assert len(data) == 1 + 1 + 15 + 1                       # ;LAYER_COUNT:15
    assert data[0].startswith(";FLAVOR:Marlin") and data[0].rstrip().endswith("4.13.0")
    assert "Ender 3 Custom Start G-code" in data[1] and ";LAYER:" not in data[1]
    assert data[2].startswith(";LAYER:0\n") and data[-2].startswith(";LAYER:14\n")
    assert data[-1].endswith(";End of Gcode\n") and "M84" in data[-1]


def test_script_keeps_cura_list(tmp_path, shown):
    mod = _load()
    text = open(SRC, newline="").read()
    data = cura_gcode_list(text)
    given = list(data)
    script = mod.GcodeOpt()
    script._settings = {"executable": _exe(tmp_path), "profile": "ender3", "max_slowdown": 0.03}
    out = script.execute(data)
    assert data == given                                      # the list handed in is not modified
    assert len(out) == len(data)
    for i in (0, 1, len(data) - 1):                           # header, start and end G-code exactly as given
        assert out[i] == data[i]
    changed = 0
    for i in range(2, len(data) - 1):                         # each layer keeps its place and its own lines
        a, b = data[i], out[i]
        assert b.split("\n", 1)[0] == a.split("\n", 1)[0]     # ;LAYER:n
        assert b.rstrip("\n").rsplit("\n", 1)[-1] == a.rstrip("\n").rsplit("\n", 1)[-1]   # ;TIME_ELAPSED:
        kept, replaced, inside = 0, 0, False
        for line in b.split("\n")[:-1]:
            if line.startswith("; gcode-opt begin: replaces "):
                replaced += int(line.split()[4])
                inside = True
            elif line.startswith("; gcode-opt end"):
                inside = False
            elif not inside:
                kept += 1
        assert kept + replaced == a.count("\n"), i          # every input line of the layer accounted for
        changed += replaced > 0
    assert changed >= 10
    # the joined list is exactly what gcode-opt writes for the whole file
    ref = tmp_path / "ref.gcode"
    subprocess.run([sys.executable, "-m", "gcode_opt", "process", SRC, "-o", str(ref), "--profile", "ender3",
                    "--max-slowdown", "0.03", "-q"], check=True)
    assert "".join(out) == open(ref, newline="").read()
    dst = tmp_path / "out.gcode"
    dst.write_bytes("".join(out).encode())
    assert verify(SRC, str(dst), load_profile("ender3"))["blocks"] > 100
    assert shown == []


def test_failure_reaches_the_user_and_keeps_the_gcode(tmp_path, shown):
    mod = _load()
    data = cura_gcode_list(open(SRC, newline="").read())
    script = mod.GcodeOpt()
    script._settings = {"executable": _exe(tmp_path, "#!/bin/sh\necho 'gcode-opt: x.gcode: boom' >&2\nexit 2\n"),
                        "profile": "auto", "max_slowdown": 0.03}
    out = script.execute(list(data))
    assert out == data
    assert len(shown) == 1 and shown[0].title == "gcode-opt" and shown[0].kind == "error"
    assert "boom" in shown[0].text and "not re-timed" in shown[0].text


def test_missing_executable_reaches_the_user(tmp_path, shown):
    mod = _load()
    data = ["header\n", ";LAYER:0\nG1 X1 E1\n"]
    script = mod.GcodeOpt()
    script._settings = {"executable": str(tmp_path / "nowhere" / "gcode-opt"), "profile": "auto",
                        "max_slowdown": 0.03}
    assert script.execute(list(data)) == data
    assert len(shown) == 1 and "full path" in shown[0].text


def test_block_across_items_or_in_start_gcode_is_left_as_sliced():
    mod = _load()
    data = [";FLAVOR:Marlin\n", "G28\nG1 X0 E1\n", ";LAYER:0\nG1 X1 E2\n", ";LAYER:1\nG1 X2 E3\n", "M84\n"]
    blk = "; gcode-opt begin: replaces {} lines, kind=line\nG1 X9 E{}\n; gcode-opt end\n"
    # a block over the last line of layer 0 and the first of layer 1, one inside the start G-code,
    # one inside layer 1 (kept)
    text = (";FLAVOR:Marlin\nG28\n" + blk.format(1, 1) + ";LAYER:0\n" + blk.format(2, 2)
            + blk.format(1, 3) + "M84\n")
    out, reverted = mod.put_back(data, text)
    assert reverted == 2
    assert out[:3] == data[:3] and out[4] == data[4]
    assert out[3] == ";LAYER:1\n" + blk.format(1, 3)


def test_output_that_does_not_match_is_refused():
    mod = _load()
    data = ["h\n", ";LAYER:0\nG1 X1\n"]
    with pytest.raises(ValueError):
        mod.put_back(data, "h\n;LAYER:0\nG1 X2\n")
    with pytest.raises(ValueError):
        mod.put_back(data, "h\n;LAYER:0\n")
