"""distinct.distinct against np.unique (plain form), bit for bit, dtype and shape: random and
edge arrays (empty, one value, ints of several widths, floats with -0.0 / 0.0, NaNs, infs,
complex with NaN, bools, 2-D)."""
import numpy as np
import pytest

from gcode_opt.distinct import distinct


def _cases(seed):
    rng = np.random.default_rng(seed)
    yield np.array([], float)
    yield np.array([7])
    yield rng.integers(0, 20, 500)
    yield rng.integers(-3, 3, 64).astype(np.int8)
    yield rng.normal(size=300).round(1)
    yield np.array([0.0, -0.0, 1.0, -0.0, 0.0])
    yield np.array([np.nan, 1.0, np.nan, 2.0, np.inf, -np.inf, np.nan])
    yield np.array([np.nan, np.nan])
    yield rng.integers(0, 5, (4, 6))
    yield np.array([1 + 2j, np.nan, 1 + 2j, 3j])
    yield rng.integers(0, 2, 50).astype(bool)
    x = rng.normal(size=1000)
    x[rng.integers(0, 1000, 50)] = np.nan
    yield np.concatenate([x, x[:100]])


@pytest.mark.parametrize("seed", range(4))
def test_same_as_np_unique(seed):
    for c in _cases(seed):
        a, b = np.unique(c), distinct(c)
        assert a.dtype == b.dtype and a.shape == b.shape
        assert a.tobytes() == b.tobytes(), c


def test_leaves_its_argument_alone():
    x = np.array([3.0, 1.0, 2.0, 1.0])
    distinct(x)
    assert x.tolist() == [3.0, 1.0, 2.0, 1.0]


def test_a_run_does_not_import_numpy_ma(tmp_path):
    # every np.unique / np.setdiff1d on a run's path is distinct now (numpy.ma: ~8 ms of import)
    import os
    import subprocess
    import sys
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    runs = ", ".join(f"(['process', {os.path.join(root, 'sample_gcode', f)!r}, '-o', {str(tmp_path / f)!r}, "
                     f"'-q', '--profile', {p!r}])" for f, p in (("prusa_gyroid_arcs.gcode", "prusa-mk3s"),
                                                                 ("prusa_klipper.gcode", "voron24")))
    code = f"import sys; from gcode_opt import cli; [cli.main(a) for a in ({runs},)]; print('numpy.ma' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"
