"""What every run imports: a process run loads neither numpy.random (with secrets, hmac and
hashlib's OpenSSL: ~6.3 MB resident) nor importlib.resources nor json; the bit probes draw
their numbers from probe_rng instead."""
import subprocess
import sys
from pathlib import Path

import numpy as np

from gcode_opt.probe_rng import ProbeRng

ROOT = Path(__file__).resolve().parent.parent
HEAVY = ("numpy.random", "hashlib", "_hashlib", "secrets", "importlib.resources", "json")


def test_a_process_run_does_not_import_the_heavy_modules(tmp_path):
    code = (
        "import runpy, sys\n"
        f"sys.argv = ['gcode_opt', 'process', {str(ROOT / 'sample_gcode' / 'prusa_gyroid.gcode')!r},"
        f" '-o', {str(tmp_path / 'out.gcode')!r}, '-q']\n"
        "try:\n"
        "    runpy.run_module('gcode_opt', run_name='__main__')\n"
        "except SystemExit as e:\n"
        "    assert not e.code, e.code\n"
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n")
    got = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert got.returncode == 0, got.stderr
    assert (tmp_path / "out.gcode").stat().st_size > 0
    assert got.stdout.strip().splitlines()[-1] == "[]"


def test_probe_rng_draws_are_repeatable_and_in_range():
    a, b = ProbeRng(5), ProbeRng(5)
    x, y = a.uniform(-2.0, 3.0, (7, 300)), b.uniform(-2.0, 3.0, (7, 300))
    assert x.shape == (7, 300) and np.array_equal(x, y)
    assert x.min() > -2.0 and x.max() < 3.0
    assert not np.array_equal(ProbeRng(6).uniform(size=100), ProbeRng(5).uniform(size=100))
    # successive draws of one generator differ (its counter moves on)
    assert not np.array_equal(a.uniform(size=100), a.uniform(size=100))


def test_probe_rng_shapes_of_the_draws_the_probes_use():
    r = ProbeRng(1)
    n = 200_000
    z = r.normal(size=n)
    assert np.isfinite(z).all()
    assert abs(z.mean()) < 0.02 and abs(z.std() - 1.0) < 0.02      # unit variance, centred
    assert (z > 3.0).mean() > 0.001                                 # tails reach past 3 sigma
    e = r.exponential(2.0, n)
    assert e.min() > 0.0 and abs(e.mean() - 2.0) < 0.05
    ln = r.lognormal(0.0, 6.0, n)
    assert ln.min() > 0.0 and np.log10(ln.max() / ln.min()) > 12   # over 12 decades, as _window_sums_ok wants
    c = r.choice([-1.0, 1.0], n)
    assert set(np.unique(c)) == {-1.0, 1.0} and abs(c.mean()) < 0.02
    u = r.random(n)
    assert u.min() > 0.0 and u.max() < 1.0 and np.unique(u).size > 0.99 * n
