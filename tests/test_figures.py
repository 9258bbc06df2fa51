"""`gcode-opt figures` writes the paper's seven figures, every one a readable PNG."""
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from gcode_opt.cli import main  # noqa: E402
from gcode_opt.report import figures  # noqa: E402


def test_figures_writes_seven_pngs(tmp_path, capsys):
    out = tmp_path / "figs"
    assert main(["figures", "-o", str(out)]) == 0
    names = sorted(os.listdir(out))
    assert names == sorted(figures.NAMES) and len(names) == 7
    printed = capsys.readouterr().out.split()
    assert len(printed) == 7
    for n in names:
        img = mpimg.imread(str(out / n))
        assert img.shape[0] > 300 and img.shape[1] > 500
        assert float(np.std(img[..., :3])) > 0.02, n


def test_trapezoid_and_laws_cover_the_path():
    t, laws, trap = figures.line_curves()
    for _, x, vx, _ in laws + [(None, *trap)]:
        assert x[0] == pytest.approx(0.0, abs=1e-12) and x[-1] == pytest.approx(1.0, abs=1e-9)
        assert np.sum(0.5 * (vx[1:] + vx[:-1]) * np.diff(t)) == pytest.approx(1.0, rel=1e-4)
    t, laws, trap = figures.semicircle_curves()
    for _, phi, w, _ in laws:
        assert phi[-1] == pytest.approx(math.pi, rel=1e-9) and w[0] == pytest.approx(0, abs=1e-8)


def test_paper_ellipse_law_differs_from_the_correct_one():
    t, laws, trap, e = figures.ellipse_curves()
    for al, p, pd, pdd, paper in laws:
        assert p[0] == pytest.approx(0, abs=1e-9) and p[-1] == pytest.approx(2 * math.pi, rel=1e-9)
        assert paper is not None
        # same boundary values, different law (MATH.md: the paper's equation (31) is wrong)
        assert paper[1][-1] == pytest.approx(2 * math.pi, rel=1e-6)
        assert np.max(np.abs(paper[2] - pd)) > 1e-2
