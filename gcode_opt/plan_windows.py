"""The windowed pipeline's planning (issue 8: the strokes never all alive): analyse spills the
strokes to a StrokeStore (pipeline.analyse's store: a SpilledInputs, which makes their
plan_inputs as they come, before their records are written) and the candidate tables are
made a window at a time over a StoredStrokes
(schedule.candidates_in_windows); the budget runs, the rewrite, the measure and the summary
then read the same StoredStrokes (pipeline._process: GCODE_OPT_WINDOWED=1).

The same bits as the list path, written file and summary, on the plates and the samples
tested, files with arcs included (tests/test_speed53_wire53_windowed.py: the arcs'
candidates take the file's quadrature levels, schedule.candidates_in_windows)."""
from __future__ import annotations

import os

import numpy as np

# strokes a window (GCODE_OPT_WINDOW): 1536 since session 61 (1024 before, benchmarks/win52/command.md):
# the windows' fixed costs paid a third less often at the same peak RSS on the gyroid plate (its
# chains' calls and budget runs grow with the window: 2048 +1 MB, 2560 +4.4 MB; benchmarks/window61.md)
WINDOW = 1536
# where GCODE_OPT_WINDOW is unset, a file of few curves is planned in larger windows
# (window_for; analyse spills as before): up to MAX_WINDOW strokes, with at most ~HEAVY_ROWS curves and chains, the
# strokes whose windows grow the peak (their geometry, the chains' candidate calls and
# re-plans), ~930 a window of 1536 on the gyroid plate.  Rectilinear plate (3.2 k curves of
# 52 k strokes): windows of 4096, -98 M instructions, peak +0.2 MB (8192: +1.1 MB for -16 M
# more); the gyroid plate keeps 1536 (benchmarks/lead62.md)
MAX_WINDOW = 4096
HEAVY_ROWS = 900
LEVEL_ROWS = 512       # arcs' / curves' rows a candidates call at least (candidates_in_windows' level_rows)
LINE_ROWS = 4096       # lines' rows a candidates call at least (its line_rows; plan.py's one-call chunk: 16 k)
# strokes a plan_inputs_windowed call at least (a window if larger): its fixed costs a call
# (chains.classify's geometry blocks, a numpy pass a column) paid 35-51 times at 1024, ~35 %
# of the pass on the plates (benchmarks/inputs56.md).  SpilledInputs plans a window's
# strokes a call instead (its docstring: the analyse heap and the peak)
PIN_ROWS = 4096
# the candidate tables' beta and KE set aside in a file through the budget runs where the
# strokes' store is a file (plan.Candidates.set_aside_weights)
ASIDE_WEIGHTS = True


def window_size():
    """GCODE_OPT_WINDOWED=1: the strokes a window of the windowed pipeline (GCODE_OPT_WINDOW,
    default WINDOW); else None (the list path, the default)."""
    if os.environ.get("GCODE_OPT_WINDOWED", "") in ("", "0"):
        return None
    got = int(os.environ.get("GCODE_OPT_WINDOW", "") or WINDOW)
    if got < 1:
        raise ValueError("GCODE_OPT_WINDOW must be >= 1")
    return got


def window_fixed():
    """Whether GCODE_OPT_WINDOW sets the window (then every pass takes it as it is; else the
    window follows the file's curves: window_for)."""
    return os.environ.get("GCODE_OPT_WINDOW", "") != ""


def window_for(window, codes):
    """The planning window of strokes whose plan_kind codes are codes: as many strokes as hold
    HEAVY_ROWS curves and chains at the file's share of them, between window and MAX_WINDOW
    (a file of no curve: MAX_WINDOW)."""
    from .schedule import C_CHAIN, C_CURVE
    if window >= MAX_WINDOW:
        return window
    heavy = int(np.count_nonzero((codes == C_CURVE) | (codes == C_CHAIN)))
    if not heavy:
        return MAX_WINDOW
    return int(min(MAX_WINDOW, max(window, HEAVY_ROWS * len(codes) // heavy)))


def plan_inputs_windowed(store, profile, opts, rows, geoms=None):
    """plan_inputs of the strokes of store, made `rows` strokes at a time and joined
    (stored_strokes.join_plan_inputs): the same PlanInput as one call over the list.  The
    strokes plan_inputs changes (chains' marks, corners' v0 / v1) are written back.
    geoms: a geom_keep.GeomKeep that keeps the curve geometry plan_inputs made."""
    from .schedule import plan_inputs
    from .stored_strokes import join_plan_inputs
    parts = []
    for lo in range(0, len(store) or 1, rows):        # (no stroke: the PlanInput of none, as the list's)
        sts = store.load(lo, lo + rows)
        parts.append(plan_inputs(sts, profile, opts, end_cols=geoms is not None))
        if geoms is not None:
            geoms.put(lo, sts, parts[-1].plan_kind_codes)
        store.rewrite(np.arange(lo, lo + len(sts), dtype=np.int64), sts)
        del sts
    return join_plan_inputs(parts)


class SpilledInputs:
    """What pipeline.analyse spills its finished strokes to on the windowed path (its store:
    append): their plan_inputs made, and their curve geometry kept (GeomKeep), from the
    strokes analyse holds, before their records are written -- each record encoded once,
    not loaded, planned and written back after analyse (plan_inputs_windowed: its
    StrokeStore.rewrite was half the windowed encodes, benchmarks/store59.md).  The
    strokes come final (their firmware sums made, analyse's sums.done, and the next stroke
    closed: next_u set); they are held until `rows` at least have come (a window's: a
    plan_inputs call's fixed costs paid once for them; analyse spills ~2.3 k strokes at a
    time on the gyroid plate, ~10 k on the rectilinear), or plan_input() is asked.  Held
    until PIN_ROWS (4096) instead, -49 M instructions on the rectilinear plate, the
    strokes and plan_inputs' temporaries raised analyse's heap (gyroid 44 -> 52 MiB), and
    with the round's other changes the gyroid's windowed peak went bimodal, 67.0 or 68.2 MB
    (benchmarks/store59.md).  plan_inputs gives the same PlanInput on any cut of the
    strokes (tests/test_speed59_store59_spill.py)."""

    def __init__(self, store, profile, opts, window, rows=None, adapt=False):
        from .geom_keep import GeomKeep
        self.store, self.profile, self.opts = store, profile, opts
        self.rows = rows or window
        self.adapt = adapt              # (the planning window follows the file's curves: window_for)
        self.geoms = GeomKeep(window, profile, store.folder)
        self.parts = []
        self.held = []                  # strokes appended, not yet planned nor stored

    def __len__(self):
        return len(self.store) + len(self.held)

    def append(self, strokes):
        """strokes (a list) after the ones appended: those held planned and stored in one
        call once they are `rows` at least."""
        self.held += strokes
        if len(self.held) >= self.rows:
            self._planned()

    def _planned(self):
        """The strokes held planned, their geometry kept, their records written."""
        from .schedule import plan_inputs
        sts, self.held = self.held, []
        pin = plan_inputs(sts, self.profile, self.opts, end_cols=True, spilled=True)     # (end_cols: for geoms.put)
        self.geoms.put(len(self.store), sts, pin.plan_kind_codes)
        self.store.append(sts)
        self.parts.append(pin)

    def plan_input(self):
        """The PlanInput of every stroke appended (the rest held planned and stored first;
        of no stroke: the list's of none), once: the parts let go as they are joined (they
        are a PlanInput's size: ~4 MB on the rectilinear plate, held through the
        candidates by the caller's reference to this object otherwise)."""
        from .stored_strokes import join_plan_inputs
        if self.held or not self.parts:
            self._planned()
        parts, self.parts = self.parts, None
        return join_plan_inputs(parts)


def planned_strokes(store, profile, opts, window):
    """(PlanInput, StoredStrokes) of the strokes of store for the budget runs: plan_inputs
    as analyse spilled them (store a SpilledInputs), else (a StrokeStore filled otherwise)
    PIN_ROWS strokes at a time (a window if larger); and with alpha "auto" the candidate
    tables a window at a time (the arcs' and curves' LEVEL_ROWS rows a call at least, the
    lines' LINE_ROWS), put where
    plan_strokes finds them (pin.cached, as its first call leaves them).  The StoredStrokes
    keeps the chains' memos (chain_T: state the runs' bits depend on, a second pass's too)
    in its side table."""
    from .geom_keep import GeomKeep
    from .stored_strokes import StoredStrokes, curve_geometry
    if isinstance(store, SpilledInputs):
        adapt = store.adapt
        pin, geoms, store = store.plan_input(), store.geoms, store.store
        if adapt:           # (the geometry kept by analyse's windows: given back by rows, any window)
            window = window_for(window, pin.plan_kind_codes)
    else:
        # (the curve geometry plan_inputs makes, kept for the later loads of its window: geom_keep)
        geoms = GeomKeep(window, profile, store.folder)
        pin = plan_inputs_windowed(store, profile, opts, max(window, PIN_ROWS), geoms)
    strokes = StoredStrokes(store, window, on_load=curve_geometry(pin.plan_kind_codes, profile, geoms),
                            keep=("chain_T",), geoms=geoms)
    if opts.alpha == "auto" and len(strokes):
        pin.cached = candidates_windowed(strokes, pin, profile, opts)
    strokes.on_load = None      # (the runs make a window's curve geometry as they segment it)
    return pin, strokes


def candidates_windowed(strokes, pin, profile, opts):
    """What schedule._candidates leaves in pin.cached (alpha "auto"): the candidate tables
    made on the windows' bounds of strokes (a StoredStrokes), the strokes whose candidate is
    not finite failed, the lines' inputs kept for the runs and the rest set aside."""
    from .schedule import (_faults_of, _file_store, _plan_kind_codes_of, _rows_by_kind, after_candidates,
                           candidates_in_windows)
    rows = _rows_by_kind(strokes, _plan_kind_codes_of(strokes, pin))
    failed = _faults_of(pin.fault)
    cands, nonfinite = candidates_in_windows(strokes, pin, profile, opts, rows, failed, strokes.bounds(),
                                             level_rows=LEVEL_ROWS, line_rows=LINE_ROWS)
    # the entries' beta and KE, which the runs read only at their chosen entries, beside the
    # store (its folder: the output's disk), not held through the runs (benchmarks/mem59.md)
    store = _file_store(strokes)
    if store is not None and ASIDE_WEIGHTS:
        cands.set_aside_weights(store.folder)
    after_candidates(pin, rows, failed, nonfinite)
    return cands, None, failed
