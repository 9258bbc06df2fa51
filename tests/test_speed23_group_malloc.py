"""The command line's glibc malloc thresholds (gcode_opt/malloc_policy.py, issue 8, s23):
they must change no byte of the output nor any figure of the summary (a run with the
policy against one without it, GCODE_OPT_MALLOC=default: the independent reference), they
must take effect (freed MiB-sized blocks reused, not faulted in anew), and they must stay
off when the user set glibc's own knobs or asked for the default."""
import json
import os
import subprocess
import sys

import pytest

from gcode_opt import malloc_policy

SAMPLES = "sample_gcode/"
_GLIBC = sys.platform.startswith("linux") and "glibc" in " ".join(__import__("platform").libc_ver())
_SKIP = ("timing", "elapsed", "cpu", "rss", "version")


def _env(**kw):
    env = {k: v for k, v in os.environ.items() if k not in malloc_policy._USER_KNOBS and k != "GCODE_OPT_MALLOC"}
    env["PYTHONPATH"] = os.getcwd()
    env.update(kw)
    return env


def _strip(o):
    if isinstance(o, dict):
        return {k: _strip(v) for k, v in o.items() if k not in ("input", "output") and not any(s in k for s in _SKIP)}
    if isinstance(o, list):
        return [_strip(x) for x in o]
    return o


def test_off_when_asked_or_user_knobs():
    assert malloc_policy.apply({"GCODE_OPT_MALLOC": "default"}) is False
    assert malloc_policy.apply({"MALLOC_TRIM_THRESHOLD_": "131072"}) is False
    assert malloc_policy.apply({"GLIBC_TUNABLES": "glibc.malloc.mmap_threshold=131072"}) is False


_FAULTS = """
import resource, sys
from gcode_opt import malloc_policy
on = malloc_policy.apply()
import numpy as np
f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(6):               # 40 MiB in 1 MiB blocks, touched, all dropped (a pass's temporaries)
    keep = [np.ones(1 << 17) for _ in range(40)]
    del keep
print(on, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
"""


@pytest.mark.skipif(not _GLIBC, reason="glibc only")
def test_takes_effect():
    got = {}
    for mode in ("policy", "default"):
        env = _env() if mode == "policy" else _env(GCODE_OPT_MALLOC="default")
        out = subprocess.run([sys.executable, "-c", _FAULTS], env=env, capture_output=True, text=True, check=True)
        on, faults = out.stdout.split()
        got[mode] = (on, int(faults))
    assert got["policy"][0] == "True" and got["default"][0] == "False"
    # without it the freed heap top (40 MiB > glibc's dynamic trim threshold) goes back to the
    # system and every round faults its pages in anew (~10 k faults); with it, the first round only
    assert got["default"][1] > 40000
    assert got["policy"][1] < got["default"][1] / 3


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3")])
def test_same_output_with_and_without(name, prof, tmp_path):
    res = {}
    for mode in ("policy", "default"):
        env = _env() if mode == "policy" else _env(GCODE_OPT_MALLOC="default")
        out, js = tmp_path / f"{mode}.gcode", tmp_path / f"{mode}.json"
        subprocess.run([sys.executable, "-m", "gcode_opt", "process", SAMPLES + name, "-o", str(out), "--profile",
                        prof, "--json", str(js), "-q"], env=env, check=True)
        res[mode] = (out.read_bytes(), _strip(json.loads(js.read_text())))
    assert res["policy"][0] == res["default"][0]
    assert res["policy"][1] == res["default"][1]
