"""stroke_block making a block's head and start texts itself (issue 8, s24 "front":
head as (kind, n_segments, T, T_was, beta, svl), x0_text and y0_text None) must give the
bytes it gives from the texts pipeline's f-strings make (pipeline._HEAD_TEXT, f"{x:.8f}"):
on every line stroke of real runs (Marlin and Klipper, whose head carries the cruise-ratio
line), and on those calls with T, T_was, beta and the start moved to odd values (NaN,
+-inf, -0.0, tiny, huge, halfway cases of the 4-decimal rounding)."""
import math
import random
from pathlib import Path

import pytest

from gcode_opt import emit, pipeline as pl
from gcode_opt.profile import load_profile

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "stroke_block"),
                                reason="no compiled emit core")
SAMPLES = Path(__file__).resolve().parents[1] / "sample_gcode"


def _texts(args):
    """The call with the head and start as texts (what the code before this change passed)."""
    a = list(args)
    kind, n_segs, t, t_was, beta, svl = a[4]
    a[4] = pl._HEAD_TEXT(emit.BEGIN, a[3], kind, n_segs, t, t_was, beta, svl)
    a[8], a[9] = f"{a[10]:.8f}", f"{a[11]:.8f}"
    return a


@pytest.fixture(scope="module")
def calls(tmp_path_factory):
    got = []
    real = CORE.stroke_block

    class Spy:
        def __getattr__(self, k):
            return getattr(CORE, k)

        @staticmethod
        def stroke_block(*args):
            got.append(args)
            return real(*args)
    mp = pytest.MonkeyPatch()
    mp.setattr(emit, "CORE_MOD", Spy())
    d = tmp_path_factory.mktemp("head")
    try:
        for name, prof in (("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24")):
            pl.process(str(SAMPLES / name), str(d / "o.gcode"), load_profile(prof), pl.Options())
    finally:
        mp.undo()
    return got


def test_real_calls_same_bytes(calls):
    assert len(calls) > 300
    n_bytes = n_svl = 0
    for args in calls:
        assert isinstance(args[4], tuple) and args[8] is None and args[9] is None
        want = CORE.stroke_block(*_texts(args))
        got = CORE.stroke_block(*args)
        assert got == want
        n_bytes += got is not None
        n_svl += bool(args[4][5])
    assert n_bytes > 0.9 * len(calls) and n_svl > 50


_ODD = [math.nan, math.inf, -math.inf, -0.0, 0.0, 5e-324, 1e-5, 0.00005, 0.00015, 0.12345, 0.12355, 2.5e-5,
        123456.78905, 1e22, -1e300, 1.0 / 3.0, 99999.99995]


def test_odd_figures_same_bytes(calls):
    rng = random.Random(5)
    picks = [a for a in calls if CORE.stroke_block(*a) is not None][:40]
    assert picks
    n = 0
    for args in picks:
        for _ in range(30):
            a = list(args)
            kind, n_segs, t, t_was, beta, svl = a[4]
            pick = (lambda: rng.choice(_ODD) if rng.random() < 0.5 else rng.uniform(-1, 1) * 10 ** rng.randrange(-9, 9))
            a[4] = (kind, n_segs, pick(), pick(), pick(), svl)
            want = CORE.stroke_block(*_texts(a))
            got = CORE.stroke_block(*a)
            assert got == want, a[4]
            n += got is not None
            # the start moved by a few ulps / to another rounding: the same as the texts
            # (the block itself may decline: the start is not on the path then)
            b = list(a)
            b[10] = math.nextafter(a[10], math.inf) if rng.random() < 0.5 else round(a[10], 9) + 5e-9
            assert CORE.stroke_block(*b) == CORE.stroke_block(*_texts(b))
    assert n > 0.9 * 40 * 30 * len(picks) / 40


def test_odd_spec_declines(calls):
    """A spec of other types is declined (None: pipeline's Python path), never an error."""
    args = next(a for a in calls if CORE.stroke_block(*a) is not None)
    kind, n_segs, t, t_was, beta, svl = args[4]
    for spec in ((kind, 1.5, t, t_was, beta, svl), (kind, n_segs, str(t), t_was, beta, svl),
                 (kind, n_segs, t, t_was, 1, svl), (kind, n_segs, t), ("l\u00efne", n_segs, t, t_was, beta, svl),
                 (None, n_segs, t, t_was, beta, svl), (kind, 2 ** 70, t, t_was, beta, svl)):
        a = list(args)
        a[4] = spec
        assert CORE.stroke_block(*a) is None
    a = list(args)
    a[8] = a[9] = None
    a[10] = "1.0"                    # a start that is not a float: no text made, declined
    assert CORE.stroke_block(*a) is None
