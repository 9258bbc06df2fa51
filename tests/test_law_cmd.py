"""`gcode-opt law`: the table round-trips -- integrating its speed over t gives the path
length, its first/last speeds are v0/v1, its positions lie on the path."""
import csv
import json
import math
import os

import numpy as np
import pytest

from gcode_opt.cli import main
from gcode_opt.report.ellipse import Ellipse

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLE = os.path.join(ROOT, "sample_gcode", "prusa_mk3s_rectilinear.gcode")
ARCS = os.path.join(ROOT, "sample_gcode", "edge", "arcs.gcode")


def _simpson(y, t):
    """Composite Simpson on an even number of equal intervals."""
    h = t[1] - t[0]
    return h / 3 * (y[0] + y[-1] + 4 * y[1:-1:2].sum() + 2 * y[2:-1:2].sum())


def _run(tmp_path, args, fmt="csv"):
    out = tmp_path / f"law.{fmt}"
    assert main(["law", *args, "--format", fmt, "-o", str(out)]) == 0
    if fmt == "json":
        d = json.loads(out.read_text())
        return d, {c: np.array([r[i] for r in d["rows"]]) for i, c in enumerate(d["columns"])}
    lines = out.read_text().splitlines()
    assert lines[0].startswith("# gcode-opt law: ")
    meta = json.loads(lines[0][len("# gcode-opt law: "):])
    rows = list(csv.reader(lines[1:]))
    cols = {c: np.array([float(r[i]) for r in rows[1:]]) for i, c in enumerate(rows[0])}
    return meta, cols


def _check_common(meta, c, v0, v1, rel=1e-6):
    t = c["t_s"]
    assert t[0] == 0 and t[-1] == pytest.approx(meta["duration_s"], rel=1e-12)
    assert _simpson(c["v_mm_s"], t) == pytest.approx(meta["length_mm"], rel=rel)
    assert c["s_mm"][-1] == pytest.approx(meta["length_mm"], rel=1e-9)
    assert c["v_mm_s"][0] == pytest.approx(v0, abs=1e-6 * max(1, abs(v0)))
    assert c["v_mm_s"][-1] == pytest.approx(v1, abs=1e-6 * max(1, abs(v1)))
    assert np.all(np.diff(c["s_mm"]) >= -1e-12)
    np.testing.assert_allclose(np.hypot(c["vx_mm_s"], c["vy_mm_s"]), np.abs(c["v_mm_s"]), atol=1e-9)
    np.testing.assert_allclose(np.hypot(c["a_t_mm_s2"], c["a_n_mm_s2"]), c["a_mm_s2"], rtol=1e-12)
    np.testing.assert_allclose(np.hypot(c["ax_mm_s2"], c["ay_mm_s2"]), c["a_mm_s2"], rtol=1e-9, atol=1e-9)
    # the table is self-consistent: position differences follow the speed
    ds = np.hypot(np.diff(c["x_mm"]), np.diff(c["y_mm"]))
    assert np.sum(ds) == pytest.approx(meta["length_mm"], rel=1e-3)


def test_line_round_trip(tmp_path):
    meta, c = _run(tmp_path, ["--line", "0,1,1,-1", "--beta", "0.01", "--points", "2001"])
    _check_common(meta, c, 0.0, 0.0, rel=1e-9)
    assert meta["length_mm"] == pytest.approx(math.sqrt(5))
    # on the line y = -2x + 1
    np.testing.assert_allclose(c["y_mm"], -2 * c["x_mm"] + 1, atol=1e-12)
    assert np.all(c["a_n_mm_s2"] == 0)


def test_line_end_speeds_alpha_mass_json(tmp_path):
    meta, c = _run(tmp_path, ["--line", "10,20,40,60", "--alpha", "0.004", "--mass", "0.5", "--duration", "0.8",
                              "--v0", "20", "--v1", "35", "--points", "1601"], fmt="json")
    assert meta["beta_s2"] == pytest.approx(0.002) and meta["alpha_s2_kg"] == pytest.approx(0.004)
    _check_common(meta, c, 20.0, 35.0, rel=1e-9)
    assert (c["x_mm"][-1], c["y_mm"][-1]) == pytest.approx((40.0, 60.0))
    np.testing.assert_allclose((c["x_mm"] - 10) * 40 - (c["y_mm"] - 20) * 30, 0, atol=1e-9)


def test_circle_round_trip(tmp_path):
    meta, c = _run(tmp_path, ["--circle", "5,-3,2,30,-270", "--beta", "0.05", "--points", "2001"])
    _check_common(meta, c, 0.0, 0.0, rel=1e-7)
    assert meta["length_mm"] == pytest.approx(2 * 1.5 * math.pi)
    np.testing.assert_allclose(np.hypot(c["x_mm"] - 5, c["y_mm"] + 3), 2.0, atol=1e-12)
    th1 = math.radians(30 - 270)
    assert (c["x_mm"][-1], c["y_mm"][-1]) == pytest.approx((5 + 2 * math.cos(th1), -3 + 2 * math.sin(th1)))
    np.testing.assert_allclose(c["a_n_mm_s2"], c["v_mm_s"] ** 2 / 2.0, rtol=1e-12)
    # clockwise: the velocity is tangent, turning right: (x-c) x v < 0
    cross = (c["x_mm"] - 5) * c["vy_mm_s"] - (c["y_mm"] + 3) * c["vx_mm_s"]
    assert np.all(cross[1:-1] < 0)


def test_ellipse_round_trip(tmp_path):
    meta, c = _run(tmp_path, ["--ellipse", "1,2", "--beta", "0.01", "--points", "2001"])
    e = Ellipse(1, 2)
    _check_common(meta, c, 0.0, 0.0, rel=1e-7)
    assert meta["length_mm"] == pytest.approx(e.length_d)
    np.testing.assert_allclose(c["x_mm"] ** 2 + (c["y_mm"] / 2) ** 2, 1.0, atol=1e-12)
    assert (c["x_mm"][-1], c["y_mm"][-1]) == pytest.approx((1.0, 0.0), abs=1e-9)
    p = e.p_of_s(c["s_mm"])
    np.testing.assert_allclose(c["a_n_mm_s2"], e.kappa_p(p) * c["v_mm_s"] ** 2, rtol=1e-9, atol=1e-12)


def test_gcode_stroke(tmp_path):
    meta, c = _run(tmp_path, ["--gcode", SAMPLE, "--line-number", "681", "--profile", "prusa-mk3s",
                              "--beta", "0.02", "--points", "1001"])
    path = meta["path"]
    assert path["first_line"] == 681
    assert meta["duration_s"] == path["firmware_time_s"]
    _check_common(meta, c, path["firmware_v0_mm_s"], path["firmware_v1_mm_s"], rel=1e-8)
    assert (c["x_mm"][0], c["y_mm"][0]) == pytest.approx((path["x0_mm"], path["y0_mm"]))
    assert (c["x_mm"][-1], c["y_mm"][-1]) == pytest.approx((path["x1_mm"], path["y1_mm"]))


def test_gcode_arc(tmp_path):
    meta, c = _run(tmp_path, ["--gcode", ARCS, "--line-number", "12", "--profile", "generic-klipper",
                              "--alpha", "0.01", "--points", "1001"])
    assert meta["path"]["kind"] == "circle"
    _check_common(meta, c, meta["v0_mm_s"], meta["v1_mm_s"], rel=1e-7)
    p = meta["path"]
    np.testing.assert_allclose(np.hypot(c["x_mm"] - p["cx_mm"], c["y_mm"] - p["cy_mm"]), p["r_mm"], atol=1e-9)


def test_law_needs_a_weight(capsys):
    assert main(["law", "--line", "0,0,1,0"]) == 2
    assert "--beta" in capsys.readouterr().err
