"""A windowed run's line plans let go and made again (issue 8, plans53): schedule.plan_strokes
over a StoredStrokes keeps only the lines' figures (retime, reason, t_pred, a2_pred; the
plans let go a window at a time, schedule._line_figures), and the rewrite makes them again a
window of rows at a time (schedule.segs_for / _LinesAgain).  Against the reference (the same
runs keeping every plan, schedule.LAZY_LINES off), on real samples: the same figures, every
row's plan made again the same bits (arrays, figures, shape, commands) for windows of 1, 7
and more rows than the file has, at most one window's line plans held; and the rewrite from
the store writes the same bytes, ranges, digests and reasons (compiled and text path).  A
line of a (class, T, beta) met before is judged on that plan's figures (schedule._line_figures),
not segmented again: the same figures."""
import io

import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc
from gcode_opt.profile import load_profile
from gcode_opt.stored_strokes import StoredStrokes, curve_geometry, join_plan_inputs
from gcode_opt.stroke_store import StrokeStore

from test_speed52_runs52_windows import seg_bits

SAMPLES = "sample_gcode/"
# the rectilinear sample by default (~6 s in all); the arcs, curves and chains of the others
# (~40 s) with -m slow
CASES = [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 64),
         pytest.param("prusa_gyroid_arcs.gcode", "prusa-mk3s", 7, marks=pytest.mark.slow),
         pytest.param("prusa_benchy_like.gcode", "voron24", 300, marks=pytest.mark.slow)]
FIGURES = ("T", "beta", "retime", "t_pred", "a2_pred")


@pytest.fixture(autouse=True)
def _chains_eager(monkeypatch):
    """The lines alone let go here (the chains' plans kept: test_speed54_chainplans_lazy.py)."""
    monkeypatch.setattr(sc, "LAZY_CHAINS", False)


def _stored_plan(name, prof_name, window):
    """(strokes: a StoredStrokes of that window, its store, prof, opts, the plan of its
    budget runs), plan_inputs and the candidates made a window at a time (as
    test_speed52_runs52_windows.runs)."""
    path = SAMPLES + name
    prof = load_profile(prof_name)
    opts = pl.Options(features=feat.default_selection(path)[0])
    store, sim0 = pl.analyse(path, prof, opts, StrokeStore(in_memory=True))
    parts = []
    for lo in range(0, len(store), window):
        sts = store.load(lo, lo + window)
        parts.append(sc.plan_inputs(sts, prof, opts))
        store.rewrite(np.arange(lo, lo + len(sts), dtype=np.int64), sts)
    pin = join_plan_inputs(parts)
    strokes = StoredStrokes(store, window, on_load=curve_geometry(pin.plan_kind_codes, prof), keep=("chain_T",))
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
    failed = sc._faults_of(pin.fault)
    cands, nonfinite = sc.candidates_in_windows(strokes, pin, prof, opts, rows, failed, strokes.bounds())
    for i in nonfinite:
        failed.setdefault(int(i), "error: planning (non-finite)")
    pin.cached = (cands, None, failed)
    strokes.on_load = None
    plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
    return strokes, store, prof, opts, plan, pin


_EAGER = {}


def _plans(name, prof_name, window, monkeypatch):
    """(the lazy run: strokes, store, prof, opts, plan, pin; the eager plan's figures and seg_bits)"""
    if (name, window) not in _EAGER:
        with monkeypatch.context() as m:
            m.setattr(sc, "LAZY_LINES", False)
            strokes, store, _, _, plan, _ = _stored_plan(name, prof_name, window)
            assert plan.remake is None
            _EAGER[name, window] = ({k: getattr(plan, k).copy() for k in FIGURES}, list(plan.reason),
                                    [seg_bits(p) for p in plan.segs])
            store.close()
    return _stored_plan(name, prof_name, window), _EAGER[name, window]


@pytest.mark.parametrize("name,prof_name,window", CASES)
def test_lazy_plans_are_the_eager_ones(name, prof_name, window, monkeypatch):
    known = [0]                 # rows judged on their key's figures (_line_figures), not segmented
    figures, segments = sc._line_figures, sc._line_segments

    def judged(fn, rows, *a):
        known[0] += rows.size
        return figures(fn, rows, *a)

    def made(sts, *a, **k):
        known[0] -= len(sts) if sc.LAZY_LINES else 0
        return segments(sts, *a, **k)
    monkeypatch.setattr(sc, "_line_figures", judged)
    monkeypatch.setattr(sc, "_line_segments", made)
    (strokes, store, _, _, plan, pin), (fig, reason, segs) = _plans(name, prof_name, window, monkeypatch)
    # the rectilinear sample's lines repeat (a key's rows, met in many windows)
    assert (known[0] > 100) == ("rectilinear" in name)
    with store:
        for k in FIGURES:
            assert getattr(plan, k).tobytes() == fig[k].tobytes(), k
        assert list(plan.reason) == reason
        kind = pin.plan_kind_codes
        lines = np.flatnonzero(plan.retime & (kind == sc.C_LINE))
        assert lines.size > 10                  # (lines re-timed: plans compared)
        # the lines' plans let go by the runs, the other kinds' kept as they are
        assert all(plan.segs[i] is None for i in lines.tolist())
        assert all(seg_bits(plan.segs[i]) == segs[i] for i in range(len(segs)) if i not in set(lines.tolist()))
        every = np.arange(len(strokes))
        for w in (1, 7, 64, len(strokes) + 1):  # the rewrite's windows of rows, any size
            before = None
            for a in range(0, every.size, w):
                rows = every[a:a + w]
                sc.segs_for(plan, rows, strokes)
                for i in rows.tolist():
                    assert seg_bits(plan.segs[i]) == segs[i], (w, i)
                if before is not None:          # the window before let go (its lines' plans)
                    gone = np.intersect1d(before, lines)
                    assert all(plan.segs[i] is None for i in gone.tolist())
                before = rows
            sc.segs_for(plan, every[:0], strokes)
            assert all(plan.segs[i] is None for i in lines.tolist())


def _rewritten(path, strokes, plan, prof, opts, text_stream):
    digests = {}
    if text_stream:
        fh = io.StringIO(newline="")
        ranges = pl.rewrite(path, fh, strokes, plan, prof, opts, digests)
        got = fh.getvalue().encode("utf-8", "surrogateescape")
    else:
        import tempfile
        with tempfile.NamedTemporaryFile("w+", encoding="utf-8", errors="surrogateescape", newline="") as fh:
            ranges = pl.rewrite(path, fh, strokes, plan, prof, opts, digests)
            fh.flush()
            got = open(fh.name, "rb").read()
    return got, [tuple(r) for r in ranges], digests, list(plan.reason), plan.retime.tolist()


@pytest.mark.parametrize("name,prof_name,window", CASES)
@pytest.mark.parametrize("text_stream", (False, True))
def test_rewrite_of_lazy_plan_is_the_eager_ones(name, prof_name, window, text_stream, monkeypatch):
    path = SAMPLES + name
    with monkeypatch.context() as m:
        m.setattr(sc, "LAZY_LINES", False)
        strokes, store, prof, opts, plan, _ = _stored_plan(name, prof_name, window)
        with store:
            want = _rewritten(path, strokes, plan, prof, opts, text_stream)
    strokes, store, prof, opts, plan, _ = _stored_plan(name, prof_name, window)
    assert plan.remake is not None
    with store:
        got = _rewritten(path, strokes, plan, prof, opts, text_stream)
    assert got == want
    assert len(want[1]) > 10


def test_second_pass_of_lazy_plan(tmp_path):
    """A second pass over a lazy plan: _restored's copy (Plan.copy carries remake) rewritten
    with the first pass's blocks to reuse (_Reuse, whose plans the rewrite let go: those
    blocks made again) writes the first pass's bytes, ranges and digests."""
    name, prof_name, window = CASES[0]
    path = SAMPLES + name
    strokes, store, prof, opts, plan, pin = _stored_plan(name, prof_name, window)
    with store:
        first = tmp_path / "first.gcode"
        digests = {}
        with open(first, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
            ranges = pl.rewrite(path, fh, strokes, plan, prof, opts, digests)
        again = pl._restored(plan, pin, [])
        assert again.remake is plan.remake
        reuse = pl._Reuse(str(first), ranges, plan.segs, plan.beta, digests)
        buf, d2 = io.StringIO(newline=""), {}
        r2 = pl.rewrite(path, buf, strokes, again, prof, opts, d2, reuse)
        reuse.close()
    assert buf.getvalue().encode("utf-8", "surrogateescape") == first.read_bytes()
    assert [tuple(r) for r in r2] == [tuple(r) for r in ranges]
    assert d2 == digests and len(d2) > 10
