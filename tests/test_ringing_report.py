"""report/ringing.py: the ringing figures and plot the report shows."""
from __future__ import annotations

import os

import numpy as np

from gcode_opt import ringing as rg
from gcode_opt.profile import load_profile
from gcode_opt.report.ringing import ringing_data, ringing_plot

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SRC = os.path.join(ROOT, "sample_gcode", "prusa_klipper.gcode")


def test_same_file_no_change_and_a_png():
    d = ringing_data(SRC, SRC, load_profile("voron24"), length_d=20.0)
    h = d["headline"]
    assert h["rms_um"]["before"] > 0 and h["rms_um"]["change"] == 0.0
    assert d["stretch"]["before"]["x_um"] == d["stretch"]["after"]["x_um"]
    s = np.asarray(d["stretch"]["before"]["s_mm"])
    assert s[0] >= d["stretch"]["from_mm"] - 1e-6 and s[-1] <= d["stretch"]["from_mm"] + 20.0 + 1e-6
    assert np.all(np.diff(s) >= -1e-9)                        # path distance runs forward
    assert ringing_plot(d)[:8] == b"\x89PNG\r\n\x1a\n"


def test_busiest_stretch_is_where_the_ringing_is():
    """The chosen window holds more ringing energy than any other window of the same length,
    checked by densely sampling the exact ringing over time and binning by path distance."""
    p = load_profile("voron24")
    tr = rg.trace(SRC, p)
    model = rg.model_of(p)
    L = 100.0
    s0 = rg.busiest_stretch(tr, model, L)
    t = np.linspace(0.0, tr.t0[-4], 400_001)
    r2 = sum(rg.response(tr, model, a).at(t) ** 2 for a in "xy")
    s = rg.s_at_t(tr, t)
    starts = np.arange(0.0, s[-1] - L, L / 2)
    e = np.array([r2[(s >= a) & (s < a + L)].sum() for a in starts])
    chosen = r2[(s >= s0) & (s < s0 + L)].sum()
    assert chosen >= 0.9 * e.max()


def test_summary_and_text_rows():
    p = load_profile("voron24")
    s = rg.summary(SRC, SRC, p)
    assert s["change"]["rms_um"]["change"] == 0.0 and s["before"] == s["after"]
    rows = rg.text_rows(rg.figures(SRC, rg.with_shaper(p, "ei")))
    assert [r[0] for r in rows] == ["ringing RMS / peak", "ringing excited by", "shaper smoothing"]
    assert "shaper ei" in rows[0][1]
