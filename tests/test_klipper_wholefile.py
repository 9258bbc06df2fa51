"""Real Klipper confirms the whole-file int|a|^2 dt reduction (issue 9, "Done means").

For each bundled Klipper-flavour sample (its `--profile auto` flavour is klipper), processed
as the CLI does with default options (auto profile, default feature selection), real
Klipper's planner (../shared/klipper, tests/klipper_oracle.py) plays the original and the
output; its whole-file change of int |a_xy|^2 dt is the reference.  Checked against it,
within 3 percentage points:
  * the headline gcode-opt prints (summary["whole_file"]["int_a2_change"], which is also
    summary["coverage"]["whole_file"]["int_a2_change"]);
  * the firmware model under the oracle's definitions and machine (model_metrics).
Klipper must also accept the output and stop no more often than on the original.
The reference figures come from Klipper's own planner; nothing is copied from our code.
"""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest

import klipper_oracle as ko
from gcode_opt import features as feat
from gcode_opt.detect import auto_profile
from gcode_opt.pipeline import Options, process

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "sample_gcode"
TOL_PP = 0.03                  # issue 9: within 3 percentage points


def _auto(path):
    with contextlib.redirect_stderr(io.StringIO()):
        return auto_profile(str(path)).profile


def _klipper_samples():
    return [p.name for p in sorted(SAMPLES.glob("*.gcode")) if _auto(p).flavour == "klipper"]


KLIPPER_SAMPLES = _klipper_samples()
FAST = "prusa_klipper.gcode"      # the smallest; the others run with -m slow


def test_there_are_klipper_flavour_samples():
    # the new full-speed gyroid and the file without comments are Klipper-flavour too
    assert {"prusa_klipper.gcode", "prusa_gyroid_fullspeed_klipper.gcode",
            "prusa_klipper_no_comments.gcode"} <= set(KLIPPER_SAMPLES)


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    root = tmp_path_factory.mktemp("wholefile")
    done = {}

    def get(name):
        if name not in done:
            src = SAMPLES / name
            prof = _auto(src)
            features, _ = feat.default_selection(str(src))
            dst = root / name
            summary = process(str(src), str(dst), prof, Options(features=features))
            done[name] = (src, dst, prof, summary)
        return done[name]
    return get


def _change(after, before):
    return after / before - 1.0


@pytest.mark.parametrize("name", [pytest.param(n, marks=[] if n == FAST else [pytest.mark.slow])
                                  for n in KLIPPER_SAMPLES])
def test_whole_file_reduction_confirmed_by_klipper(processed, name):
    ko.oracle_or_skip()
    src, dst, prof, s = processed(name)
    k0, k1 = ko.run_oracle(src, prof), ko.run_oracle(dst, prof)
    assert k0["errors"] == [] and k1["errors"] == [], (k0["errors"][:3], k1["errors"][:3])
    assert k1["n_internal_full_stops"] <= k0["n_internal_full_stops"]
    klipper = _change(k1["int_a2_xy"], k0["int_a2_xy"])
    assert klipper < -0.05, f"{name}: Klipper sees no whole-file reduction ({klipper:+.1%})"
    headline = s["whole_file"]["int_a2_change"]
    assert s["coverage"]["whole_file"]["int_a2_change"] == headline
    assert abs(headline - klipper) <= TOL_PP, \
        f"{name}: gcode-opt says {headline:+.1%}, Klipper {klipper:+.1%}"
    machine = ko.oracle_machine(prof)
    m0, m1 = ko.model_metrics(src, machine), ko.model_metrics(dst, machine)
    model = _change(m1["int_a2_xy"], m0["int_a2_xy"])
    assert abs(model - klipper) <= TOL_PP, f"{name}: model {model:+.1%}, Klipper {klipper:+.1%}"
