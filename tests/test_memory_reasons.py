"""plan._reasons builds the per-stroke reasons as the nested np.where it replaced did
(same text per stroke, later masks winning), without fixed-width unicode temporaries."""
import numpy as np

from gcode_opt.plan import _reasons


def test_reasons_match_nested_where():
    rng = np.random.default_rng(5)
    for n in (0, 1, 7, 1000):
        use = rng.random(n) < 0.4
        none_ok = rng.random(n) < 0.3
        got = _reasons(n, "original is better within the time budget",
                       (none_ok, "no law within limits"), (use, "retimed"))
        want = np.where(use, "retimed",
                        np.where(none_ok, "no law within limits", "original is better within the time budget"))
        assert got.dtype == object and got.shape == (n,)
        assert [str(x) for x in want] == list(got)


def test_reasons_are_not_cut_to_a_width():
    out = _reasons(3, "", (np.array([True, False, False]), "x"))
    out[1] = "error: emission (a reason longer than any given here)"   # later reasons are written in place
    assert out[1].endswith("here)") and out[0] == "x" and out[2] == ""
