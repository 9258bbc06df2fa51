"""The file's plan: from the strokes the analyse pass found to the law and the segments
of each one that is re-timed.

  plan_inputs   per-stroke limits (speed cap from F, overshoot per feature, machine and
                hotend flow; acceleration cap per axis; segment time), arcs and curves
                adjusting theirs; slower corners (corners.py) when opts.corner_budget_r > 0;
  plan_strokes  candidates per kind of stroke (lines: plan.py; arcs: arcs.py; curves:
                curves.py; chains: chains.py), the time budget spent across them
                (plan.plan_auto), then the segments each chosen stroke will be played as,
                and the budget re-spent once with the segments' predicted times.

Kinds are a registry (KINDS: kind -> Kind with adjust_inputs / candidates / fixed_alpha /
segments): the planner below is generic over them.

Faults stay with their stroke: a batch that raises is retried in halves down to the stroke
at fault (plan.isolate); a non-finite candidate, plan or segment drops that stroke only,
with its reason.
"""
from __future__ import annotations

import binascii
import math
from array import array
from functools import partial
from itertools import compress, islice, repeat
from operator import attrgetter, is_, is_not, itemgetter

import numpy as np

from .distinct import column_classes_first, distinct
from . import chains
from . import corners
from . import curves
from . import objfields
from .corners import junction_commands
from .laws import circle
from .coverage import feature_overshoot_r
from .plan import (Candidates, Plan, PlanInput, PiecesMemo, SpilledCandidates, candidate_pieces, input_faults, isolate,
                   pieces_once_of, plan_auto, plan_fixed_alpha)
from .profile import Profile
from .segments import (RowPlan, SegmentPlan, SegmentRules, line_classes, plan_once, plan_segments, stored_line_classes,
                       slowed_original)
from .line_spill import LineSpill
from .spill_file import SpillFile, block_plans, plan_arrays, plan_heads
from .stored_strokes import StoredStrokes, StrokeRows, stored
from .strokes import K_ARC, K_CHAIN, K_CURVE, K_LINE, stroke_fields


def _line_segments(sts, T, beta, rules, same=None, cmd=None):
    """plan_segments of lines; same: their line classes (segments.line_classes), whose
    lines at one (T, beta) are planned once (segments.plan_once), or None; cmd: their
    corner_cmd0 (a bool array), or None (plan_once reads them)."""
    if same is not None:
        got = plan_once(lambda s, t, b: plan_segments(s, t, b, rules), sts, T, beta, same, cmd)
        if got is not None:
            return got
    return plan_segments(sts, T, beta, rules)


def _line_candidates(pin, rows):
    """candidate_pieces of the lines rows, each set of inputs made once where many repeat
    (plan.pieces_once; _lines_repeat)."""
    if _lines_repeat(pin, rows):
        return pieces_once_of(lambda p, r, t: candidate_pieces(p, r, t), pin, rows)
    return candidate_pieces(pin.take(rows), rows, pin.T_orig)


class Kind:
    """What the planner needs of one kind of stroke (each callable takes the stroke rows
    of that kind; None = nothing to do):
      adjust_inputs(pin, strokes, rows, profile)            its PlanInput rows
      candidates(pin, rows, strokes, profile, rules)        (T, beta, I, KE) tables
      fixed_alpha(plan, pin, rows, strokes, profile, alpha, rules)   --alpha A, into plan
      segments(strokes, T, beta, rules, profile)            a SegmentPlan per stroke
    batch: segment plans depend on the whole batch (solved together; SegmentCache)."""

    def __init__(self, candidates, fixed_alpha, segments, adjust_inputs=None, batch=True):
        self.candidates, self.fixed_alpha, self.segments = candidates, fixed_alpha, segments
        self.adjust_inputs, self.batch = adjust_inputs, batch


def _fixed_lines(plan, pin, rows, strokes, profile, alpha, rules):
    plan.put(rows, plan_fixed_alpha(pin.take(rows), alpha))


def _arcs():
    """arcs.py, imported by a run's first arc stroke (~2.8 M instructions: most files have none)."""
    from . import arcs
    return arcs


KINDS = {
    K_LINE: Kind(lambda pin, r, sts, prof, rules: _Pieces(_line_candidates(pin, r)), _fixed_lines,
                 lambda sts, T, b, rules, prof, same=None, cmd=None: _line_segments(sts, T, b, rules, same, cmd),
                 batch=False),
    K_ARC: Kind(lambda pin, r, sts, prof, rules: _arcs().candidates_arc(pin, r, sts),
                lambda plan, pin, r, sts, prof, alpha, rules: _arcs().fixed_alpha_arc(plan, pin, r, sts, alpha),
                lambda sts, T, b, rules, prof: _arcs().plan_arc_segments(sts, T, b, rules, prof),
                lambda pin, sts, r, prof: _arcs().adjust_plan_inputs(pin, sts, r, prof)),
    K_CURVE: Kind(lambda pin, r, sts, prof, rules: curves.candidates_curve(pin, r, sts, prof),
                  lambda plan, pin, r, sts, prof, alpha, rules:
                  curves.fixed_alpha_curve(plan, pin, r, sts, prof, alpha),
                  curves.plan_curve_segments, curves.adjust_plan_inputs),
    K_CHAIN: Kind(chains.candidates_chain, chains.fixed_alpha_chain, chains.plan_chain_segments,
                  chains.adjust_plan_inputs),
}


# each kind's code (its place in KINDS) in the per-stroke kind arrays: an int8 compare an
# element, where an object array's `kinds == K_CURVE` made a str compare of each (~100
# instructions an element, a few dozen passes over the strokes: with summary.py's compares
# of reasons, features and kinds, 1.7 % of the rectilinear plate's instructions)
KIND_CODE = {k: c for c, k in enumerate(KINDS)}
C_LINE, C_ARC, C_CURVE, C_CHAIN = (KIND_CODE[k] for k in (K_LINE, K_ARC, K_CURVE, K_CHAIN))
NO_KIND = -1            # a stroke of a kind the planner has none of (in no kind's rows)


# kinds whose segment plans are each stroke's own when their batch sent no circle law to
# Newton (curves.plan_curve_segments: the circle solves, then per row; SegmentCache)
ROW_KINDS = (K_CURVE,)


_FEATURE, _KIND, _CHAIN_T = attrgetter("feature"), attrgetter("kind"), attrgetter("chain_T")
# the strokes' floats plan_inputs reads (as np.array([s.name for s in strokes], float))
_PIN_FLOATS = ("length_d", "ux", "uy", "v_feed", "e_per_mm", "accel", "v0", "v1", "time_t", "int_a2")


def _float_columns(strokes, names):
    """{name: np.array([s.name for s in strokes], float)} for each of names: the compiled
    core's reading (strokes.stroke_fields: a float's own double, None's NaN, a bool's 1.0 /
    0.0, the doubles np.array makes of them) where every stroke's value is one of those,
    else that field read here.  One pass in C, not a Python attribute read a stroke and
    field (~10 fields of ~52 k strokes on the rectilinear plate)."""
    got = stroke_fields(strokes, names) if strokes else None
    # (the kinds tested in one pass over the whole array, mostly all fine, not a strided pass a column)
    ok = None
    if got is not None:
        ok = [True] * len(names) if (got[1] <= 2).all() else (got[1] <= 2).all(axis=0).tolist()
    out = {}
    for j, name in enumerate(names):
        if got is not None and ok[j]:
            out[name] = np.ascontiguousarray(got[0][:, j])
        else:
            out[name] = np.array(list(map(attrgetter(name), strokes)), float)
    return out


def _lim_columns(strokes, profile):
    """(min(lim.v_max, profile's max velocity), lim.ax_max, lim.ay_max) of every stroke as
    float arrays, read once a Limits object: few distinct ones are shared by all the strokes
    (state.Limits is copy-on-write), the same values read a stroke at a time."""
    ul, which = objfields.by_identity(strokes, "lim")      # each distinct object, in first-seen order
    v_lim = np.array([min(lim.v_max, profile.max_velocity_v) for lim in ul], float)[which]
    ax = np.array([lim.ax_max for lim in ul], float)[which]
    ay = np.array([lim.ay_max for lim in ul], float)[which]
    return v_lim, ax, ay


def _kind_codes(strokes):
    """Every stroke's kind as its KIND_CODE (int8; NO_KIND: none of KINDS)."""
    code = objfields.codes(strokes, "kind", KIND_CODE)     # (None where a kind is none of KINDS)
    if code is not None:
        return code.astype(np.int8)
    return np.fromiter(map(KIND_CODE.get, map(_KIND, strokes), repeat(NO_KIND)), np.int8, len(strokes))


def plan_kind_codes(strokes, codes=None):
    """The KIND_CODE of chains.plan_kind of every stroke (int8; its two fields read by
    map, not a Python call a stroke); codes: _kind_codes(strokes) if the caller has it (a
    new array is returned)."""
    n = len(strokes)
    codes = _kind_codes(strokes) if codes is None else codes.copy()
    got = stroke_fields(strokes, ("chain_T",)) if n and type(strokes) is list else None
    if got is not None and (got[1] <= 3).all():     # each chain_T read (4: unset, its read raises)
        chain = got[1][:, 0] != 1                   # kind 1: None
    else:
        chain = np.fromiter(map(_IS_NOT_NONE, map(_CHAIN_T, strokes)), bool, n)
    if chain.any():
        codes[chain & (codes == C_CURVE)] = C_CHAIN
    return codes


def _overshoots(strokes, opts):
    """Every stroke's feature_overshoot_r(st.feature, opts) (a float array): a call a
    feature, not a stroke (it reads only the feature and opts); each stroke's feature coded
    in one compiled pass where the core is built (objfields.codes), its feature's value
    gathered (the same floats)."""
    n = len(strokes)
    feat_of = {}
    code = objfields.codes(strokes, "feature", feat_of, add=True)
    if code is not None:
        try:
            return np.array([feature_overshoot_r(f, opts) for f in feat_of], float)[code]
        except TypeError:
            pass
    feats = list(map(_FEATURE, strokes))
    try:
        over_of = {f: feature_overshoot_r(f, opts) for f in set(feats)}
    except TypeError:                     # (an unhashable feature: a call a stroke)
        over_of = None
    return (np.array([feature_overshoot_r(f, opts) for f in feats], float) if over_of is None
            else np.fromiter(map(over_of.__getitem__, feats), float, n))


# code -> kind name, NO_KIND's (the last place) None: the names corners.py compares
_KIND_NAMES = np.array(list(KINDS) + [None], dtype=object)


def plan_inputs(strokes, profile: Profile, opts, end_cols=False, spilled=False) -> PlanInput:
    """The PlanInput of strokes (chains marked, corners lowered).  end_cols: the curve
    geometry's blocks keep their end turns as columns for geom_keep.put (curves.build_geoms).
    spilled: the strokes are stored and let go next (plan_windows.SpilledInputs): the chains
    are marked with one ChainMemo, not a new one each (~2.4 k instructions, ~16 k chains on
    the gyroid plate): a stored memo is the mark alone, each stroke loaded gets its own."""
    n = len(strokes)
    col = _float_columns(strokes, _PIN_FLOATS)
    with np.errstate(all="ignore"):           # non-finite inputs are caught per stroke below
        L, ux, uy, v_feed = col["length_d"], col["ux"], col["uy"], col["v_feed"]
        v_lim, ax, ay = _lim_columns(strokes, profile)
        area = math.pi * (profile.filament_diameter_d / 2) ** 2
        e_mm = col["e_per_mm"]
        v_flow = np.where(e_mm > 0, profile.max_volumetric_flow / np.maximum(e_mm * area, 1e-12), np.inf)
        # (one feature_overshoot_r call a feature, not a stroke: it reads only the feature and opts)
        over_r = _overshoots(strokes, opts)
        v_cap = np.minimum(np.minimum(v_feed * (1 + over_r), v_lim), v_flow)
        v_cap = np.maximum(v_cap, np.minimum(v_feed, v_lim))    # never below what the slicer asked
        # firmware caps each axis' share of the acceleration (Marlin M201, Klipper max_accel)
        a_axis = np.minimum(np.where(abs(ux) > 1e-12, ax / abs(ux), np.inf),
                            np.where(abs(uy) > 1e-12, ay / abs(uy), np.inf))
        a_cap = np.minimum(col["accel"], a_axis)
        m = profile.moving_mass_x_kg * ux ** 2 + profile.moving_mass_y_kg * uy ** 2
        m2 = profile.moving_mass_x_kg ** 2 * ux ** 2 + profile.moving_mass_y_kg ** 2 * uy ** 2
        seg_t = max(profile.min_segment_time_t, 1.0 / profile.max_segment_rate)
        pin = PlanInput(L, col["v0"], col["v1"], v_cap, a_cap, col["time_t"], col["int_a2"], m2 / m,
                        np.full(n, 3 * seg_t))
    del col
    pin.v_cap, pin.a_cap, pin.mass_r = pin.v_cap.astype(float), pin.a_cap.astype(float), pin.mass_r.astype(float)
    failed = {}
    # a curve whose vertices cap the speed below its feed is a chain
    codes = _kind_codes(strokes)
    memo = chains.ChainMemo() if spilled else None
    isolate(lambda r: chains.classify(strokes, r, profile, end_cols, memo), np.flatnonzero(codes == C_CURVE),
            "planning", failed)
    codes = plan_kind_codes(strokes, codes)
    for k, kind in KINDS.items():
        if kind.adjust_inputs is not None:
            rows = _not_failed(np.flatnonzero(codes == KIND_CODE[k]), failed)
            isolate(lambda r: kind.adjust_inputs(pin, strokes, r, profile), rows, "planning", failed)
    # --corners R: lower line strokes' end speeds at sharp corners (corners.py); off by default
    try:                                      # computed first, then set: a failure changes nothing
        corners.lower_corners(strokes, pin, profile, opts, _KIND_NAMES[codes])
    except Exception:                         # noqa: BLE001 -- the corners stay the firmware's
        pass
    pin.fault = input_faults(pin)             # reason per stroke, "" = fine
    for i, why in failed.items():
        pin.fault[i] = why
    # each stroke's plan_kind, for plan_strokes (chains.classify above is the one step that
    # changes them): read again there, it was ~5 ms of the rectilinear plate's planning
    pin.plan_kind_codes = codes
    return pin


def _rows_by_kind(strokes, codes=None):
    """{kind: the rows of the strokes of that plan_kind}; codes: plan_kind_codes(strokes),
    if the caller has them."""
    if codes is None:
        codes = plan_kind_codes(strokes)
    return {k: np.flatnonzero(codes == c) for k, c in KIND_CODE.items()}


def _plan_kind_codes_of(strokes, pin):
    """plan_kind_codes(strokes) as plan_inputs made them for pin (pin.plan_kind_codes),
    else made here."""
    codes = getattr(pin, "plan_kind_codes", None)
    if codes is None or len(codes) != len(strokes):
        codes = plan_kind_codes(strokes)
    return codes


class _Pieces(list):
    """A kind's candidates already as Candidates.piece()s (lines: plan.candidate_pieces)."""


LINES_LAST = True     # tests turn it off: the kinds in KINDS' order (the same tables)
CANDIDATE_ROWS = 1 << 14      # line strokes whose candidates are made at once (plan.py's
                              # CANDIDATE_CHUNK x BISECT_CHUNKS: its batches as in one call)


def _candidates(strokes, pin, profile, opts, rows, failed):
    """Candidate tables (auto) or the fixed-alpha plan of every stroke, each kind's batch
    isolated: a stroke whose planning raises or gives non-finite numbers is dropped alone."""
    n = len(strokes)
    rules = SegmentRules.for_profile(profile, opts.max_segments)
    if opts.alpha == "auto":
        cands, nonfinite = Candidates.of_pieces(n, window_pieces(strokes, pin, profile, rows, failed, rules),
                                                pin.T_orig)
        after_candidates(pin, rows, failed, nonfinite)
        return cands, None
    ok = {k: _not_failed(r, failed) for k, r in rows.items()}
    alpha = float(opts.alpha)
    fixed = Plan(n)
    fixed.T = pin.T_orig.copy()
    fixed.I_law = pin.I_orig.copy()
    fixed.reason[:] = "no law within limits"
    for k, kind in KINDS.items():
        isolate(lambda r: kind.fixed_alpha(fixed, pin, r, strokes, profile, alpha, rules), ok[k], "planning",
                failed)
    return None, fixed


def after_candidates(pin, rows, failed, nonfinite):
    """What follows the candidate tables (one call's or the windows'): the strokes whose
    candidate is not finite failed; plan_strokes' question of the lines answered while
    their inputs are here; the inputs only the candidates read let go through the budget
    runs (read back if read again)."""
    for i in nonfinite:
        failed.setdefault(int(i), "error: planning (non-finite)")
    _lines_repeat(pin, rows[K_LINE])
    pin.set_aside()


def window_pieces(strokes, pin, profile, rows, failed, rules, levels=None, lines=None, own_levels=None,
                  kinds=None):
    """The candidate pieces (Candidates.piece / SharedPiece: Candidates.of_pieces' input) of
    the strokes rows ({kind: rows}, those in failed left out), each kind's batch isolated:
    a stroke whose planning raises is dropped alone (into failed).  Every stroke's entries
    are the same bits whatever other strokes the call holds (candidates_in_windows), given
    levels: {kind: floors of its grid levels} of the circle kinds (_LEVEL_KINDS: arcs,
    candidates_arc's levels; curves, candidates_curve's) of the whole file (a kind not
    in it: the batch's own).  lines: a plan.PiecesMemo that takes the lines in (their
    pieces then come from its piece()), None: made here (pieces_once where many repeat).
    own_levels: {kind: a list given its own levels of each pass}.  With a curves' entry
    in levels or own_levels κ(s) is kept after the curves (for the next window: the
    caller lets it go, curves.drop_kappa).  kinds: those made (default all)."""
    ok = {k: _not_failed(r, failed) for k, r in rows.items()}
    pieces = []
    # the lines last: their sparse pieces (~13 MB on the rectilinear plate) are then not
    # held under the curves' and chains' solves, whose transients set the peak RSS
    order = [k for k in KINDS if k != K_LINE] + [K_LINE] if LINES_LAST else list(KINDS)
    for k in order if kinds is None else [k for k in order if k in kinds]:   # (each kind's tables kept sparse)
        lv, own = (levels or {}).get(k), (own_levels or {}).get(k)
        make = KINDS[k].candidates if k not in _LEVEL_KINDS or (lv is None and own is None) \
            else _LEVEL_KINDS[k](lv, own)
        if k == K_LINE and lines is not None:
            done = isolate(lambda r: lines.add(candidate_pieces, pin.take(r), r, pin.T_orig), ok[k], "planning",
                           failed)
            if all(got for _, got in done):
                continue
            ok[k] = np.concatenate([r for r, got in done if not got])       # (not plain: made below)
        # lines by CANDIDATE_ROWS at a time: their dense tables (4 x 23 doubles a row)
        # were ~33 MB at once on the rectilinear plate, before they were made sparse
        # (every entry is its row's own: the same tables, tests/test_speed25_alloc_*)
        # (lines all at once where many repeat: plan.pieces_once makes each set of
        # inputs once, and candidate_pieces its pieces chunk by chunk)
        step = (CANDIDATE_ROWS if not _lines_repeat(pin, ok[k]) else max(ok[k].size, 1)) if k == K_LINE \
            else max(ok[k].size, 1)
        for a in range(0, ok[k].size, step):
            got = isolate(lambda r: make(pin, r, strokes, profile, rules), ok[k][a:a + step], "planning", failed)
            # each dense table let go once made sparse: a loop variable held the last
            # one through the next kind's solve and the merge (gyroid plate: the
            # curves' 3.6 MB at the chains' peak, the chains' 12 MB at of_pieces)
            got.reverse()
            while got:
                sub, tables = got.pop()
                if type(tables) is _Pieces:           # (kept sparse by the kind, chunk by chunk)
                    pieces += tables
                else:
                    pieces.append(Candidates.piece(sub, tables, pin.T_orig))
                del sub, tables
        if k == K_CHAIN and ok[k].size >= chains.TRIM_DROPPED:
            # the chains' dense tables (~12 MB on the gyroid plate's ~16 k chains), freed
            # in the middle of the heap once sparse, given back before the lines'
            # candidates and the merge grow on top of them (that plate's candidates'
            # peak RSS ~113 -> ~106 MB)
            from .pipeline import trim_heap
            trim_heap()
    return pieces


def _curves_at(levels, own_levels):
    """KINDS[K_CURVE].candidates with candidates_curve's levels and own_levels, κ(s) kept
    (for the next window: the caller lets it go, curves.drop_kappa)."""
    return lambda pin, r, sts, prof, rules: curves.candidates_curve(pin, r, sts, prof, levels, own_levels, False)


def _arcs_at(levels, own_levels):
    """KINDS[K_ARC].candidates with candidates_arc's levels and own_levels."""
    return lambda pin, r, sts, prof, rules: _arcs().candidates_arc(pin, r, sts, levels, own_levels)


# the kinds whose candidates read their laws on their batch's quadrature grid (the circle
# law's panel levels, the largest of the batch's): made with the file's levels as a floor
_LEVEL_KINDS = {K_ARC: _arcs_at, K_CURVE: _curves_at}


def candidates_in_windows(strokes, pin, profile, opts, rows, failed, bounds, info=None, decide_first=False,
                          chain_batch=None, level_rows=0, line_rows=0):
    """_candidates' tables (auto) made window by window: Candidates.of_pieces of
    window_pieces of the strokes [bounds[j], bounds[j + 1]) of each window, the same bits
    as one call of all of them (tests/test_speed50_wina50_windows.py,
    tests/test_speed53_arcs53_windows.py).  Returns (Candidates, rows holding a non-finite
    candidate).  What makes them so:
      - the lines' inputs made once across the windows (plan.PiecesMemo), as pieces_once
        makes them across the file (each entry is its row's own);
      - the arcs' and curves' figures on the file's grid (_LEVEL_KINDS' levels): each
        pass's levels are the largest of its candidates' in the file.  Each window takes
        the largest met so far, and a window whose pass made figures on other levels than
        the file's is made again at the file's (made again on its first pass's, its
        retries are the file's: its retries' levels are read again).  decide_first: the
        first pass's levels decided over the file first (curves.curve_grid_levels,
        arcs.arc_grid_levels, ~0.02 s a plate), so only the retries can take a window
        again.  The retries' are known only once the first passes have run (a cap, the
        levels of every candidate at beta/4, was 8 on both plates where their retries' are
        4: every window would have been made again).  On both plates the largest levels
        are in the first window, and no retry makes figures: no window is made again;
      - the circle laws each arc's own (Newton's too: circle._newton_cheb), where the BLAS
        gives a row its own bits (circle.rows_invariant);
      - the chains: each chain's tables its own (as the other kinds, each row's own); the
        chains of consecutive windows are made in one call, chain_batch (None: CHAIN_BATCH)
        at a time (_WaitingChains).
    level_rows: the arcs' and the curves' candidates made for consecutive windows together
    until they hold at least that many of the kind's rows (_level_units; their strokes held
    as objects till then, as the chains'): a call's set-up paid a unit of windows, not a
    window (benchmarks/wincpu54.md); 0: a window a call.  The levels' bookkeeping below is
    a unit's.  line_rows: likewise the lines' (the other kinds', but the chains'), which
    read no stroke: a unit's rows in one call.
    info (a dict): given "levels" (the curves' file levels: first pass, retries),
    "arc_levels" (the arcs'), "redone" (windows whose arcs or curves were made again),
    "newton" (arcs Newton solved), "own" and "arc_own" (each unit's own levels a pass,
    and whether it made figures: candidates_curve's / candidates_arc's own_levels)."""
    n = len(strokes)
    rules = SegmentRules.for_profile(profile, opts.max_segments)
    todo_rows = {k: _not_failed(rows.get(k, np.zeros(0, int)), failed) for k in _LEVEL_KINDS}
    first = {K_CURVE: lambda: curves.curve_grid_levels(pin, todo_rows[K_CURVE], strokes, profile),
             K_ARC: lambda: _arcs().arc_grid_levels(pin, todo_rows[K_ARC], strokes)}
    ordered = all(r.size < 2 or bool((r[1:] >= r[:-1]).all()) for r in rows.values())
    window_rows = _WindowRows(rows, bounds, ordered)
    memo = PiecesMemo(failed)
    n0 = circle.NEWTON_ARCS[0]
    pieces = []
    nw = len(bounds) - 1
    # per circle kind: its units of windows (first window, end), the unit the window j
    # closes, the strokes of the open unit; the floors (the largest own levels met so far,
    # a pass), and per unit its pieces, the floors it took and each pass's (own levels,
    # whether it made figures)
    units = {k: _level_units(rows.get(k), bounds, level_rows if ordered else 0) for k in _LEVEL_KINDS}
    closes = {k: {e - 1: u for u, (_, e) in enumerate(units[k])} for k in _LEVEL_KINDS}
    held = {k: {} for k in _LEVEL_KINDS}
    others = [k for k in KINDS if k not in _LEVEL_KINDS and k != K_CHAIN]
    other_units = {e - 1: (a, e) for a, e in _level_units(rows.get(K_LINE), bounds, line_rows if ordered else 0)}
    levels = {k: [first[k]() if decide_first else 0, 0] for k in _LEVEL_KINDS}
    made = {k: [None] * len(units[k]) for k in _LEVEL_KINDS}
    used = {k: [None] * len(units[k]) for k in _LEVEL_KINDS}
    owns = {k: [None] * len(units[k]) for k in _LEVEL_KINDS}
    todo, redone = {}, 0
    waiting = _WaitingChains(strokes, pin, profile, failed, rules, chain_batch)

    def make(k, u, rows_u, sts):
        owns[k][u], used[k][u] = [], tuple(levels[k])
        made[k][u] = window_pieces(sts, pin, profile, {k: rows_u}, failed, rules, {k: used[k][u]},
                                   own_levels={k: owns[k][u]}, kinds=(k,))
        for p, (lv, fig) in enumerate(owns[k][u][:2]):
            levels[k][p] = max(levels[k][p], lv) if fig else levels[k][p]

    again = {k: set(range(nw)) for k in _LEVEL_KINDS}       # the windows whose units are (made) again
    while True:
        for j in sorted(set().union(*again.values())):
            got = window_rows(j, j + 1)
            sts = _window_strokes(strokes, got, bounds[j], bounds[j + 1])
            if not redone:              # (the other kinds once, a unit of windows; the chains a batch of windows)
                unit = other_units.get(j)
                if unit is not None:
                    pieces += window_pieces(strokes, pin, profile, got if unit[1] - unit[0] == 1 else
                                            window_rows(*unit),
                                            failed, rules, lines=memo, kinds=others)
                pieces += waiting.add(got.get(K_CHAIN), j == nw - 1, sts)
            for k in [k for k in _LEVEL_KINDS if j in again[k]]:
                u = closes[k].get(j)
                if u is not None and units[k][u][1] - units[k][u][0] == 1:     # (a window a unit: it is held)
                    make(k, u, got[k], sts)
                    continue
                r = got[k].tolist()
                held[k].update(zip(r, map(sts.__getitem__, r)))
                if u is not None:
                    a, e = units[k][u]
                    make(k, u, window_rows(a, e)[k], held[k])
                    held[k] = {}
        for k in _LEVEL_KINDS:
            levels[k] = _file_levels(owns[k])
            # the units whose figures were made on other levels (the largest of their own
            # and the floor) than the file's; a first pass made on the file's: its retries are
            # the file's
            todo[k] = [u for u in range(len(units[k])) if any(fig and max(lv, used[k][u][p]) != levels[k][p]
                                                              for p, (lv, fig) in enumerate(owns[k][u][:2]))]
            again[k] = {j for u in todo[k] for j in range(*units[k][u])}
        if not any(todo.values()):
            break
        redone += len(set().union(*again.values()))
    curves.drop_kappa()         # (kept from window to window: window_pieces' own_levels)
    if info is not None:
        info.update(levels=tuple(levels[K_CURVE]), arc_levels=tuple(levels[K_ARC]), redone=redone,
                    newton=circle.NEWTON_ARCS[0] - n0, own=owns[K_CURVE], arc_own=owns[K_ARC])
    # one list of every piece, held nowhere else: of_pieces empties it, each piece let go
    # once copied (a joined copy of the list, with curve's, held them all to the end)
    for k in _LEVEL_KINDS:
        for j, c in enumerate(made[k]):
            pieces += c
            made[k][j] = None
    pieces += memo.piece()
    return Candidates.of_pieces(n, pieces, pin.T_orig)


# chains of consecutive windows made in one candidates_chain call.  A quarter of a solve
# chunk: since the runs keep no chain plans (LAZY_CHAINS) the chain batches' transients set
# the windowed gyroid plate's peak (78.4 MB at 2048, 74.4 at 512, same bytes), for ~+225 M
# instructions (benchmarks/memo53.md: +285 M -> +510 M over one call at 32 windows)
CHAIN_BATCH = chains.SOLVE_CHUNK // 4


# the windowed candidates' kept chain laws (~7 MB on the gyroid plate, held from the chain
# batches through the budget runs: the windowed peak) and the chain batches' pieces (~3 MB,
# to the merge) in a temporary file beside the store's, not in memory (benchmarks/memo55.md);
# the list path keeps them in memory
SPILL_CHAIN_LAWS = True


class _WaitingChains:
    """The chains of consecutive windows made together (window_pieces of K_CHAIN), once
    `batch` of them wait or the last window is passed: each chain's tables are its own
    whatever chains a call holds, and a call's set-up (its chunks' solves, its finishing
    batches: one a segment count) is paid a batch, not a window (benchmarks/cpu52.md: a
    call a window, +605 M instructions at 32 windows on the gyroid plate; memo53.md).
    The chains' strokes are held as objects until their call (their window may be let go
    before: a StoredStrokes keeping chain_T puts the same memo objects back, so what the
    call writes in them is the row's).  With SPILL_CHAIN_LAWS the calls' kept laws and
    their pieces' masks and values go to one temporary file beside the store's
    (_law_spill), read back for the rows a run replays and by Candidates.of_pieces."""

    def __init__(self, strokes, pin, profile, failed, rules, batch=None):
        self.strokes, self.pin, self.profile, self.failed, self.rules = strokes, pin, profile, failed, rules
        self.batch = CHAIN_BATCH if batch is None else max(int(batch), 1)
        self.rows, self.held, self.n = [], {}, 0
        self.spill = None               # (made by the first call: _law_spill)

    def add(self, rows, last, strokes=None):
        """Pieces of the chains waiting with rows (an int array, or None) once a batch is due;
        strokes: those of rows indexed by row (default: the strokes')."""
        if rows is not None and rows.size:
            self.rows.append(rows)
            self.held.update(zip(rows.tolist(), map((self.strokes if strokes is None else strokes).__getitem__,
                                                    rows.tolist())))
            self.n += rows.size
        if not self.n or (self.n < self.batch and not last):
            return []
        rows, held = np.concatenate(self.rows), self.held
        self.rows, self.held, self.n = [], {}, 0
        if self.spill is None:
            self.spill = _law_spill(self.strokes)
        with chains.laws_spilled_to(self.spill or None):
            got = window_pieces(held, self.pin, self.profile, {K_CHAIN: rows}, self.failed, self.rules,
                                kinds=(K_CHAIN,))
        if self.spill:
            got = [_SpilledPiece(pc, self.spill) if type(pc) is tuple and len(pc) == 5 else pc for pc in got]
        return got


def _file_store(strokes):
    """The StrokeStore in a file the strokes are read from (a StoredStrokes over one), else None."""
    store = getattr(strokes, "store", None)
    return None if getattr(store, "in_memory", True) else store


def _store_folder(strokes):
    """The folder of the file the strokes' store spills to, else None."""
    return getattr(_file_store(strokes), "folder", None)


def _law_spill(strokes):
    """The chains' spill (chains.LawSpill) where the strokes' store spills (a StoredStrokes
    over a StrokeStore in a file: its folder, the output's disk, not a /tmp that may be
    tmpfs), or False: their laws kept in memory (strokes a list, a store in memory,
    SPILL_CHAIN_LAWS off, or no file could be made there)."""
    store = _file_store(strokes)
    if not SPILL_CHAIN_LAWS or store is None:
        return False
    try:
        return chains.LawSpill(store.folder)
    except OSError:
        return False


class _SpilledPiece:
    """A chain batch's candidate piece (Candidates.piece: rows sub, mask, vals, t_pos, bad
    rows) whose mask and values wait in the chains' spill (chains.LawSpill) until
    Candidates.of_pieces reads them (the gyroid plate's chains: ~3 MB held from their
    batches to the merge, the windowed peak); indexed and unpacked as the piece, the same
    arrays read back."""
    __slots__ = ("sub", "mask", "vals", "t_pos", "bad")

    def __init__(self, piece, spill):
        sub, mask, vals, self.t_pos, self.bad = piece
        self.sub = sub
        self.vals, self.mask = spill.put_block([vals, mask])

    def __len__(self):
        return 5

    def __getitem__(self, i):
        x = (self.sub, self.mask, self.vals, self.t_pos, self.bad)[i]
        return x.whole() if type(x) is chains._SpilledRows else x

    def __iter__(self):
        return map(self.__getitem__, range(5))


# the candidates' strokes of a window made of their records alone (StoredStrokes.take) where
# the kinds that read strokes (all but the lines) hold under this share of its rows: each
# window's load decoded, and gave the curve geometry to, every stroke of it (the rectilinear
# plate's windows: ~70 curves of 1024 strokes)
TAKE_UNDER_R = 0.5


def _window_strokes(strokes, got, lo, hi):
    """What the candidates index the rows got ({kind: rows} of the window [lo, hi)) in:
    strokes, or {row: stroke} of the rows of every kind but the lines (StoredStrokes.take:
    the strokes its load makes of them) where those are under TAKE_UNDER_R of the window's."""
    need = [r for k, r in got.items() if k != K_LINE and r.size]
    n = sum(r.size for r in need)
    if not isinstance(strokes, StoredStrokes) or not n or n >= TAKE_UNDER_R * (hi - lo):
        return strokes
    rows = np.concatenate(need).astype(np.int64)
    rows.sort()
    return dict(zip(rows.tolist(), strokes.take(rows)))


class _WindowRows:
    """window_rows(a, e): {kind: its rows in the windows a .. e - 1 ([bounds[a], bounds[e])),
    in their order} of rows ({kind: rows}), made when asked (the windows' copies, every
    row's once, were held through them); ordered: every kind's rows ascending, then views
    of them between the places of the bounds, found once for every window (two scalar
    np.searchsorted a kind a window were ~95 k instructions a window)."""
    __slots__ = ("rows", "bounds", "cut")

    def __init__(self, rows, bounds, ordered):
        self.rows, self.bounds = rows, bounds
        self.cut = [np.searchsorted(r, bounds).tolist() for r in rows.values()] if ordered else None

    def __call__(self, a, e):
        if self.cut is None:
            lo, hi = self.bounds[a], self.bounds[e]
            return {k: r[(r >= lo) & (r < hi)] for k, r in self.rows.items()}
        return {k: r[c[a]:c[e]] for (k, r), c in zip(self.rows.items(), self.cut)}


def _level_units(rows, bounds, least):
    """[(first window, end window)] of the windows [bounds[j], bounds[j + 1]) taken
    together, consecutive ones, until they hold at least `least` of rows (sorted; the last
    unit what is left); least <= 1 or no rows: a window a unit."""
    nw = len(bounds) - 1
    if least <= 1 or rows is None:
        return [(j, j + 1) for j in range(nw)]
    units, a, n = [], 0, 0
    for j, c in enumerate(np.diff(np.searchsorted(rows, bounds)).tolist()):
        n += c
        if n >= least:
            units.append((a, j + 1))
            a, n = j + 1, 0
    if a < nw:
        units.append((a, nw))
    return units


def _file_levels(owns):
    """[first pass, retries]: the levels of each pass of one call of every window's
    strokes (the largest of the windows' own: owns, candidates_curve's own_levels a
    window), 0 where no window's pass made figures (the levels are not read).  The
    levels of a pass that made no figures are read (a function) only where another
    window's did, and kept."""
    out = []
    for p in range(2):
        at = [o for o in owns if len(o) > p]
        if not any(o[p][1] for o in at):
            out.append(0)
            continue
        for o in at:
            if callable(o[p][0]):
                o[p] = (o[p][0](), o[p][1])
        out.append(max(o[p][0] for o in at))
    return out


def _not_failed(rows, failed):
    """np.array([i for i in rows if i not in failed], int): the rows (an int array) whose
    stroke has no failure, as a new array (all of them, the usual case: no Python pass)."""
    if not failed:
        return np.array(rows, int)
    rows = np.asarray(rows)
    return np.array(rows[[i not in failed for i in rows.tolist()]], int)


def _faults_of(fault):
    """{i: str(why)} of every stroke whose fault (pin.fault: its reason, "" = fine) is
    one, in the strokes' order: the truthy ones found by one cast, not a Python test a
    stroke."""
    fz = np.asarray(fault, dtype=object)
    if fz.ndim != 1:
        return {i: str(r) for i, r in enumerate(fault) if r}
    return {i: str(fz[i]) for i in np.flatnonzero(fz.astype(bool)).tolist()}


def _plan_fault(plan):
    """Rows of a plan chosen for re-timing whose figures are not finite numbers."""
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(plan.T) | ~(plan.T > 0) | ~np.isfinite(plan.I_law) | np.isnan(plan.beta)
    return plan.retime & bad


def seg_fault(seg):
    """Why a segment plan must not be written ("" = fine): every knot, speed, acceleration
    and feed finite, knots strictly increasing, accelerations and feeds above 0.  The
    verdict is kept on the plan (SegmentPlan.fault): each re-plan of the budget reuses most
    plans, and checking them again was ~15 % of planning on a 186 k-line plate."""
    known = getattr(seg, "fault", None)
    if known is not None:
        return known
    why = _seg_fault(seg)
    try:
        seg.fault = why
    except AttributeError:               # not a SegmentPlan: nothing to keep it on
        pass
    return why


def _seg_fault(seg):
    s, v, a, f = seg.s, seg.v, seg.accel, seg.feed
    if (type(s) is type(v) is type(a) is type(f) is np.ndarray and s.ndim == v.ndim == a.ndim == f.ndim == 1
            and s.dtype == _F64 and v.dtype == _F64 and a.dtype == _F64 and f.dtype == _F64
            and _fine_1d(seg, s, v, a, f)):
        return ""
    return _seg_fault_any(seg)


_F64 = np.dtype(float)


def _fine_1d(seg, s, v, a, f):
    """True when every check of _seg_fault passes on four 1-D float arrays (what the
    planners make), on Python floats: ~10 knots, where each numpy call costs more than
    the work.  False sends the plan to _seg_fault_any for its reason (the same order).
    A sum times 0 is 0 exactly when every value is finite and the sum does not overflow
    (an overflow only sends a fine plan the long way); b > a is b - a > 0 for finite
    floats (np.diff's subtraction: exact in sign)."""
    n, m = s.size, s.size + v.size
    x = np.concatenate((s, v, a, f)).tolist()
    if not (sum(x) * 0.0 == 0.0 and math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)
            and n >= 2 and a.size == n - 1 and f.size == n - 1):
        return False
    sl = x[:n]
    return (all(map(float.__lt__, sl, sl[1:])) and min(x[m:]) > 0.0
            and (m == n or min(x[n:m]) >= 0.0))


# plans checked together by settle_faults: all ~16 k chains of the gyroid plate at once
# (~40 knots each) raised the plan phase's peak RSS by ~17 MB (the flat copies, their
# masks and the int64 running counts)
SETTLE_CHUNK = 1024


def settle_faults(segs):
    """seg_fault's verdict "" kept on every SegmentPlan of `segs` (None and plans with a
    verdict skipped) that passes _fine_1d's checks, made on all of them at once in flat
    arrays (~27 k plans on the gyroid plate, ~10 µs each by _fine_1d); the others are
    left for seg_fault, which finds their reason.  The same verdicts: every check is
    elementwise (finite, > 0, >= 0, knots increasing inside each plan), each plan's
    sizes and figures are checked as _fine_1d checks them."""
    todo, ss, vs, as_, fs = [], [], [], [], []
    # RowPlans by their four blocks: checked as rows of them (_settle_rows).  Known first
    # by their knots' block alone (an int key, one identity: the four ids in a tuple were
    # ~3 k instructions a plan on the gyroid plate's ~17 k), its other three blocks those
    # of the group's first plan; a plan whose other blocks differ goes by all four
    blocks, by_s = {}, {}
    for seg in segs:
        if (type(seg) is not SegmentPlan and type(seg) is not RowPlan) or seg.fault is not None:
            continue
        if type(seg) is RowPlan and type(seg._row) is int:
            if not (math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)):
                continue
            got = by_s.get(id(seg._s))
            if got is None or not (got[0][1] is seg._v and got[0][2] is seg._accel and got[0][3] is seg._feed):
                key = (id(seg._s), id(seg._v), id(seg._accel), id(seg._feed))
                got = blocks.get(key)
                if got is None:
                    got = blocks[key] = ((seg._s, seg._v, seg._accel, seg._feed), [])
                    by_s.setdefault(key[0], got)
            got[1].append(seg)
            continue
        _take_flat(seg, todo, ss, vs, as_, fs)
    for (S, V, A, F), plans in blocks.values():
        if not _settle_rows(S, V, A, F, plans):
            for seg in plans:               # blocks of another shape: each plan's four arrays
                _take_flat(seg, todo, ss, vs, as_, fs)
    for a in range(0, len(todo), SETTLE_CHUNK):     # bounded memory: every check is per plan
        b = a + SETTLE_CHUNK
        _settle(todo[a:b], ss[a:b], vs[a:b], as_[a:b], fs[a:b])


def _take_flat(seg, todo, ss, vs, as_, fs):
    """seg and its four arrays appended to the lists where they are what _settle checks
    (1-D float64, n >= 2 knots, n - 1 accelerations and feeds) and its figures finite;
    else nothing (seg_fault finds the reason)."""
    s, v, a, f = seg.s, seg.v, seg.accel, seg.feed
    if not (type(s) is type(v) is type(a) is type(f) is np.ndarray and s.ndim == v.ndim == a.ndim == f.ndim == 1
            and s.dtype == _F64 and v.dtype == _F64 and a.dtype == _F64 and f.dtype == _F64):
        return
    n = s.size
    if not (n >= 2 and a.size == n - 1 and f.size == n - 1 and math.isfinite(seg.time_t)
            and math.isfinite(seg.int_a2)):
        return
    todo.append(seg)
    ss.append(s)
    vs.append(v)
    as_.append(a)
    fs.append(f)


def _settle_rows(S, V, A, F, plans):
    """settle_faults' checks on RowPlans `plans` (int rows, finite figures) of the blocks
    S, V, A, F, made on their rows of the blocks (segments.fine_rows: the same elementwise
    checks as _settle's; ~17 k chain plans in ~100 blocks on the gyroid plate, whose four
    views each were made and concatenated again).  False where the blocks are not 2-D
    float64 arrays of (m, K), (m, K - 1) shapes with K >= 2 (each plan is then taken alone)."""
    nd = np.ndarray
    if not (type(S) is nd and type(V) is nd and type(A) is nd and type(F) is nd
            and S.ndim == V.ndim == A.ndim == F.ndim == 2 and S.dtype == V.dtype == A.dtype == F.dtype == _F64):
        return False
    m, K = S.shape
    if not (K >= 2 and V.shape == (m, K) and A.shape == F.shape == (m, K - 1)):
        return False
    for a in range(0, len(plans), SETTLE_CHUNK):    # bounded memory: every check is per row
        part = plans[a:a + SETTLE_CHUNK]
        r = objfields.codes(part, "_row", None)
        r = _run_or_rows(np.fromiter(map(_ROW, part), np.intp, len(part)) if r is None else r)
        with np.errstate(invalid="ignore"):
            # (a run's rows are views; other rows gathered by np.take, the same rows)
            Sr, Vr, Ar, Fr = ((S[r], V[r], A[r], F[r]) if type(r) is slice
                              else (S.take(r, axis=0), V.take(r, axis=0), A.take(r, axis=0), F.take(r, axis=0)))
            # each row's checks side by side, then one all() along the rows (a reduction
            # along short rows costs ~100 instructions a row: eight were ~25 M on the gyroid plate)
            fine = np.concatenate((np.isfinite(Sr), Sr[:, 1:] > Sr[:, :-1], np.isfinite(Vr), Vr >= 0.0,
                                   np.isfinite(Ar), Ar > 0.0, np.isfinite(Fr), Fr > 0.0), axis=1).all(axis=1)
        for seg in compress(part, fine.tolist()):
            seg.fault = ""
    return True


_ROW = attrgetter("_row")


def _run_or_rows(r):
    """The rows r (intp) as a slice where they are one ascending run (a block's plans in
    its rows' order, the usual case): its rows are then views, not gathered copies (~20 M
    instructions on the gyroid plate), the same values."""
    if r.size and int(r[-1]) - int(r[0]) == r.size - 1 and (r.size == 1 or bool((np.diff(r) == 1).all())):
        return slice(int(r[0]), int(r[-1]) + 1)
    return r


def _settle(todo, ss, vs, as_, fs):
    """settle_faults' checks on the plans `todo` (their arrays ss, vs, as_, fs)."""
    with np.errstate(invalid="ignore"):
        s, v, a, f = (np.concatenate(x) for x in (ss, vs, as_, fs))
        # per plan, the count of bad entries: a cumulative count read at each plan's ends
        ok_s = np.isfinite(s)
        up = np.ones(s.size, bool)                     # s[k] > s[k - 1] within a plan
        up[1:] = s[1:] > s[:-1]
        n_s = np.array([x.size for x in ss])
        first = np.concatenate([[0], np.cumsum(n_s)[:-1]])
        up[first] = True                               # a plan's first knot follows no knot of its own
        bad_s = ~(ok_s & up)
        bad_v = ~(v >= 0.0) | ~np.isfinite(v)
        bad_a = ~(a > 0.0) | ~np.isfinite(a)
        bad_f = ~(f > 0.0) | ~np.isfinite(f)
    fine = np.ones(len(todo), bool)
    for bad, sizes in ((bad_s, n_s), (bad_v, [x.size for x in vs]), (bad_a, [x.size for x in as_]),
                       (bad_f, [x.size for x in fs])):
        ends = np.cumsum(sizes)
        c = np.concatenate([[0], np.cumsum(bad)])
        fine &= (c[ends] - c[ends - np.asarray(sizes)]) == 0
    for seg, ok in zip(todo, fine.tolist()):
        if ok:
            seg.fault = ""


def _seg_fault_any(seg):
    """_seg_fault of anything (lists, other dtypes, malformed shapes)."""
    try:
        s, v, a, f = (np.asarray(x, float) for x in (seg.s, seg.v, seg.accel, seg.feed))
    except (TypeError, ValueError):
        return "error: segments (malformed)"
    if not (np.isfinite(s).all() and np.isfinite(v).all() and np.isfinite(a).all() and np.isfinite(f).all()
            and math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)):
        return "error: segments (non-finite)"
    if len(s) < 2 or a.size != len(s) - 1 or f.size != len(s) - 1:
        return "error: segments (malformed)"
    if not (np.diff(s) > 0).all():
        return "error: segments (knots not increasing)"
    if not ((a > 0).all() and (f > 0).all() and (v >= 0).all()):
        return "error: segments (acceleration, feed or speed not above 0)"
    return ""


class SegmentCache:
    """Segment plans already made for a stroke at a given (T, beta): each re-plan of the
    budget changes the law of some strokes only, and only those are segmented again.

    Lines are planned one law at a time (every step of plan_segments is per stroke), so a
    line's plan is reused whenever its (T, beta) is the one it was made for.  Arcs and
    curves solve their laws in one batch, whose rounding may depend on the batch (~1e-16):
    their plans are reused only when the whole batch is the same, so that the result is
    always the one a fresh run would give.  Curves (ROW_KINDS) are reused row by row when
    their last batch is known to give each row its own bits (no circle solve went to
    Newton, no failure: laws/circle.NEWTON_ARCS; the BLAS gives rows their own bits:
    circle.rows_invariant); the gyroid plate's second budget run re-solved its ~3.5 k
    curves, all at the (T, beta) of the first.  Kept for the last run only.

    A line's entry is a row of two float arrays (T, beta; NaN: none) and of a list of
    plans, 24 bytes a stroke (a dict of tuples took ~210 on a plate of 48 k lines).
    keep_lines False: no line's plan kept (every line segmented each run): where a
    _RunMemo hands a later run the last one's line plans, the cache's line part hit no line
    on either plate and held ~1.2 MB of rows and the plans the last run did not keep."""

    def __init__(self):
        self.line_T = np.zeros(0)       # row -> the T its line plan was made for (NaN: none)
        self.line_beta = np.zeros(0)
        self.line_seg = []              # row -> that segment plan, or None
        self.line_why = {}              # row -> why segmenting it failed (failures only)
        self.batch = {}                 # kind -> (key, {row: seg}, {row: why})
        self.row_tb = {}                # kind -> {row: its (T, beta) bytes} when the batch is rows' own
        self.line_class = None          # row -> its segments.line_classes class (plan_strokes sets it)
        self.keep_lines = True          # the lines' plans kept (False: lookup and store pass them by)

    @staticmethod
    def _key(rows, T, beta):
        return rows.tobytes() + T[rows].tobytes() + beta[rows].tobytes()

    def _grow(self, n):
        k = len(self.line_seg)
        if n > k:
            self.line_T = np.concatenate([self.line_T, np.full(n - k, np.nan)])
            self.line_beta = np.concatenate([self.line_beta, np.full(n - k, np.nan)])
            self.line_seg += [None] * (n - k)

    def lookup_rows(self, kind, rows, T, beta):
        """{row: plan} of the rows whose plan the last batch of this kind made at their
        (T, beta), when that batch's plans are each row's own (store(own=True))."""
        tb = self.row_tb.get(kind)
        if not tb:
            return {}
        segs = self.batch[kind][1]
        got = {}
        for i, now in zip(rows.tolist(), _tb_keys(rows, T, beta)):
            k = tb.get(i)
            if k is not None and k == now and i in segs:
                got[i] = segs[i]
        return got

    def lookup(self, kind, rows, T, beta):
        if KINDS[kind].batch:
            key, segs, bad = self.batch.get(kind, (None, {}, {}))
            return (segs, bad) if key == self._key(rows, T, beta) else ({}, {})
        got, bad = {}, {}
        if not rows.size or not self.keep_lines:
            return got, bad
        self._grow(int(rows.max()) + 1)
        hit = (self.line_T[rows] == T[rows]) & (self.line_beta[rows] == beta[rows])
        hit_r = rows[hit]
        hit_l = hit_r.tolist()
        seg = self.line_seg
        if not self.line_why:                 # no failure kept (the common case): the hits' plans
            return dict(zip(hit_l, _take(seg, hit_r))), bad
        for i in hit_l:
            why = self.line_why.get(i)
            if why:
                bad[i] = why
            else:
                got[i] = seg[i]
        return got, bad

    def drop(self, kind):
        """Forget the last batch of a batch kind (its plans are not this run's): it would
        otherwise live beside the batch being made (store replaces it only after).  A
        later batch equal to it is solved again, with the same bits."""
        self.batch.pop(kind, None)
        self.row_tb.pop(kind, None)

    def store(self, kind, rows, T, beta, segs, bad, own=False):
        """The plans segs[i] (a list by row, or a dict with every row; None: none) of the
        rows made at (T, beta), bad ({row: why}) those that failed.
        own: every plan of this batch is its row's own, whatever the batch (ROW_KINDS: no
        Newton step in the circle solves, no failure, a BLAS whose rows are invariant);
        lookup_rows then reuses them row by row."""
        if KINDS[kind].batch:
            if rows.size:
                rows_l = rows.tolist()
                made = {i: segs[i] for i in rows_l if i not in bad}
                self.batch[kind] = (self._key(rows, T, beta), made, bad)
                self.row_tb[kind] = dict(zip(rows_l, _tb_keys(rows, T, beta))) if own else None
            return
        if not rows.size or not self.keep_lines:
            return
        self._grow(int(rows.max()) + 1)
        self.line_T[rows] = T[rows]
        self.line_beta[rows] = beta[rows]
        _copy_at(self.line_seg, rows, segs, rows)
        if self.line_why or bad:              # failures: a row's reason set, or dropped
            why_of = self.line_why
            for i in rows.tolist():
                why = bad.get(i, "")
                if why:
                    why_of[i] = why
                else:
                    why_of.pop(i, None)

    def forget_lines(self, rows):
        """The line plans of rows (an int array) about to be made again at another (T, beta),
        freed before the new ones are made: a budget run otherwise held both (rectilinear
        plate's second run: ~30 k plans, ~30 MB, beside their replacements).  A later run back
        at an old (T, beta) makes that plan again, with the same bits (a line's plan is its
        row's own)."""
        n = len(self.line_seg)
        rows = np.asarray(rows)
        if rows.size and rows.max() >= n:
            rows = rows[rows < n]
        if not rows.size:
            return
        self.line_T[rows] = self.line_beta[rows] = np.nan
        _clear_at(self.line_seg, rows)
        if self.line_why:
            for i in rows.tolist():
                self.line_why.pop(i, None)

    def alone(self, i):
        """Stroke i's fields changed (a lead-out): it is a line class of its own from now on."""
        cls = self.line_class
        if cls is not None and 0 <= i < cls.size:
            cls[i] = cls.max() + 1

    def forget_line(self, i):
        """Stroke i's line plan is no longer the one its (T, beta) gives (a lead-out changed)."""
        self.forget_lines(np.array([i]))


def _tb_keys(rows, T, beta):
    """[T[i].tobytes() + beta[i].tobytes() for i in rows]: for float64 T and beta, the rows
    (T, beta) pairs as 16-byte records (the same bytes, made in one pass)."""
    if T.dtype == _F64 and beta.dtype == _F64 and T.ndim == beta.ndim == 1:
        tb = np.empty((rows.size, 2))
        tb[:, 0], tb[:, 1] = T[rows], beta[rows]
        return tb.view(_TB).ravel().tolist()
    return [T[i].tobytes() + beta[i].tobytes() for i in rows.tolist()]


_TB = np.dtype((np.void, 16))


GAIN_TOL_R = 1e-9       # a plan within this of the original's int a^2 gains nothing but rounding


def set_aside_for_rewrite(pin, folder, last):
    """After a pass's plan, what only a re-plan reads let go before its rewrite and measure:
    the segment cache (a re-plan then segments every stroke again, which gives the plans a
    fresh run gives: SegmentCache) and the candidate tables, written to a temporary file
    in folder until a re-plan reads them back (plan_strokes), or dropped after the last
    pass (last).  Rectilinear plate: the run's peak RSS (its measure's) 91.8 -> 86.5 MB,
    the plan's again."""
    pin.seg_cache = None
    cached = getattr(pin, "cached", None)
    if cached is None or type(cached[0]) is not Candidates:
        return
    cands, fixed, failed = cached
    spilled = None if last else cands.spill(folder)
    if last or spilled is not None:
        pin.cached = (spilled, fixed, failed)


def drop_cached(pin):
    """What set_aside_for_rewrite kept for a re-plan, let go after the last pass (a spilled
    table's temporary file closed)."""
    cached = getattr(pin, "cached", None)
    if cached is not None and type(cached[0]) is SpilledCandidates:
        cached[0].close()
    pin.cached = None


def beats(a2_plan, a2_orig) -> bool:
    """Segments whose int a^2 is below the original's by more than rounding: a constant-
    speed stroke's segments can equal the original exactly, and then whether the last bit
    falls below decided if the stroke was rewritten, for no gain."""
    return a2_plan < a2_orig * (1.0 - GAIN_TOL_R)


def plan_strokes(strokes, pin, profile, opts, budget_t):
    """Law per stroke (plan.py), then its segments as the firmware will execute them
    (segments.py).  The segments' predicted time, not the law's, is what the print takes:
    the budget is re-spent once with the difference taken off, and a stroke whose
    segments would not beat the original trapezoid is left alone.

    Fault isolation: a stroke whose inputs are not finite, whose planning or segmenting
    raises, or whose plan holds a non-finite number keeps its original lines, with the
    reason in plan.reason (the summary counts them)."""
    rules = SegmentRules.for_profile(profile, opts.max_segments)
    # each stroke's plan_kind: the rows of each kind, and read by every re-plan for the
    # strokes it segments (KIND_CODEs)
    kind_by_row = _plan_kind_codes_of(strokes, pin)
    rows = _rows_by_kind(strokes, kind_by_row)
    cached = getattr(pin, "cached", None)    # the same strokes planned again: reuse
    if cached is None:
        fault = getattr(pin, "fault", None)
        failed = {} if fault is None else _faults_of(fault)
        cands, fixed = _candidates(strokes, pin, profile, opts, rows, failed) if len(strokes) else (None, None)
        cached = pin.cached = (cands, fixed, failed)
        # the candidates' freed temporaries given back before the plan runs: the runs' own
        # allocations then take fresh pages rather than stacking on ~10 MB glibc kept (gyroid
        # plate: peak RSS 148 -> 137-139 MB, rectilinear -2..3 MB; ~5 k more page faults)
        from .pipeline import trim_heap
        trim_heap()
    cands, fixed, failed = cached
    if type(cands) is SpilledCandidates:     # (set aside by set_aside_for_rewrite)
        cands = cands.load()
        pin.cached = (cands, fixed, failed)
    failed_rows = np.array(sorted(failed), int)
    seg_cache = getattr(pin, "seg_cache", None)
    if seg_cache is None:
        seg_cache = pin.seg_cache = SegmentCache()

    # failed strokes stay out of the budget's allocation (their figures may be NaN).  One
    # budget for every kind, spent where a second buys the most (equal marginal gain): a
    # share per kind held the vertex-capped chains to their share of the print time (MK3S
    # gyroid at full speed: chains -34 %, whole file -35 %; one budget: -75 %, -47 %, same
    # time).  No stroke ends stiffer than its original: plan_strokes leaves such a one as sliced.
    # (np.setdiff1d's sorted distinct rows, without its np.unique: distinct.py)
    every = distinct(np.concatenate([rows[k] for k in KINDS]))
    not_failed = np.ones(len(strokes), bool)
    not_failed[failed_rows] = False
    groups = [every[not_failed[every]]]
    # the strokes whose start corners.py slowed by a junction command (set before planning,
    # read by every run's _attach_commands and _keep_slowed_corners)
    cmd0 = _corner_cmd0(strokes)
    # each line's class (segments.line_classes): the lines of one class at one (T, beta)
    # are segmented once a batch (a plate's layers repeat their strokes); None where few
    # lines repeat (then every line is segmented, as before)
    line_cls = None
    # strokes not a list (stored_strokes.StoredStrokes): the runs read them a window at a time
    window = None if type(strokes) is list else getattr(strokes, "window", None)
    if _lines_repeat(pin, rows[K_LINE]):
        line_cls = np.arange(len(strokes), dtype=np.int64)
        line_cls[rows[K_LINE]] = len(strokes) + _line_classes(strokes, rows[K_LINE], window)
    seg_cache.line_class = line_cls

    # a later budget run takes the last one's outcome for each re-timed line and chain
    # whose law (T, beta) it keeps (_RunMemo), and segments only the others; not with
    # --corners (their commands and lead-outs change strokes and plans after the segments)
    reuse = REUSE_RUNS and not cmd0.any() and not getattr(pin, "corner_next", None)
    # the lines' cached plans serve a later run only where no _RunMemo does (one run with
    # a fixed alpha: none)
    seg_cache.keep_lines = opts.alpha == "auto" and not reuse
    # windowed (and no --corners: nothing is put on a line's or chain's plan after its
    # figures): the lines' and chains' plans let go a window at a time once their figures
    # are on the plan, made again by the rewrite a window at a time (segs_for; a line's
    # plan is its row's own, a chain's its (T, beta)'s, whatever its memo holds)
    lazy_lines = window is not None and reuse and LAZY_LINES
    lazy_chains = window is not None and reuse and LAZY_CHAINS
    lazy_codes = [c for c, on in ((C_LINE, lazy_lines), (C_CHAIN, lazy_chains)) if on]
    # the chains' plans the runs make, spilled for the rewrite's remake to read back
    # (in the strokes' store's folder: the output's disk, not a /tmp that may be tmpfs, RAM)
    spill = _ChainSpill.make(len(strokes), _store_folder(strokes)) if lazy_chains and SPILL_CHAINS else None
    # the lines' plans the runs make, likewise (line_spill.LineSpill: a record a (class, T, beta))
    line_spill = LineSpill.make(_store_folder(strokes)) if lazy_lines and SPILL_LINES else None
    remake = (_PlansAgain(kind_by_row, line_cls, cmd0, rules, profile, lazy_codes, strokes, spill, line_spill)
              if lazy_codes else None)
    last = [None]           # the last run's _RunMemo
    alloc_memo = {}         # plan_auto's, across the runs (plan._AllocMemo)

    def run(budget):
        plan = plan_auto(pin, budget, cands, groups, alloc_memo) if opts.alpha == "auto" else fixed.copy()
        plan.retime[failed_rows] = False
        for i in failed_rows:
            plan.reason[i] = failed[i]
        bad = _plan_fault(plan)
        plan.retime[bad] = False
        plan.reason[bad] = "error: planning (non-finite)"
        plan.segs = [None] * len(strokes)
        plan.t_pred = pin.T_orig.copy()
        plan.a2_pred = pin.I_orig.copy()
        idx = np.flatnonzero(plan.retime)
        memo, last[0] = last[0], None
        idx_in, own = idx, None
        if reuse and opts.alpha == "auto":
            k_in = kind_by_row[idx]
            own = (k_in == C_LINE) | (k_in == C_CHAIN)
            del k_in
        later = memo is not None
        if later:
            idx = memo.put_same(plan, idx, own)         # the rows left to segment
        memo = None             # (the last run's plans not held here while this one's are made)
        kind = kind_by_row[idx]
        if window is None:      # (windowed: made a window of rows at a time, as they are segmented)
            _rebuild_geometry(strokes, idx, kind, profile)
        # each row's segment plan, written as it is found or made: plan.segs itself, whose
        # rows of idx are None until then (put_same left them out); _keep_plans puts back
        # those it keeps (a dict of them all and its int keys were ~2.7 MB at the run's
        # peak on either plate)
        segs = plan.segs
        seg_failed = {}
        for k_name, kind_of in KINDS.items():
            # (lines with their classes: the same plans, made once a class and law; and their
            # corner_cmd0, read once above, not again from ~35 k strokes a run)
            fn = (lambda k, lines: lambda r: k.segments(
                _stored_rows(strokes, r) if lines and lazy_lines else list(map(strokes.__getitem__, r.tolist())),
                plan.T[r], plan.beta[r], rules, profile,
                **({"same": None if line_cls is None else line_cls[r], "cmd": cmd0[r]} if lines else {})))(
                    kind_of, k_name == K_LINE)
            if lazy_lines and k_name == K_LINE:
                _line_figures(_at_most(fn, window), idx[kind == C_LINE], window, plan, strokes, pin.I_orig, line_cls,
                              line_spill)
                continue
            if lazy_chains and k_name == K_CHAIN:
                seg_cache.drop(k_name)            # (its plans are let go: none kept for a later run)
                fn = partial(_chain_plans, strokes, plan, rules, profile, spill=spill)
                # (each part judged and let go by _window_figures as one window: of more rows than the file)
                for part in _chain_calls(idx[kind == C_CHAIN], window):
                    _window_figures(fn, part, len(strokes) + 1, plan, strokes, pin.I_orig)
                continue
            if window is not None and k_name == K_CURVE:
                fn = _curve_calls(kind_of.segments, strokes, plan, rules, profile, min(CURVE_ROWS, window))
            elif window is not None and k_name in WINDOW_KINDS:
                fn = _by_windows(fn, window, k_name in _CIRCLE_KINDS,
                                 (lambda r: _rebuild_geometry(strokes, r, kind_by_row[r], profile))
                                 if k_name == K_CHAIN else None)      # (the curves: _curve_calls)
            ii = idx[kind == KIND_CODE[k_name]]

            def solve(rows):
                """rows' plans written in segs (a failed row's left as it is); returns
                ({row: why} of the failed ones, whether each plan is its row's own)."""
                why = {}
                n0 = circle.NEWTON_ARCS[0]
                for sub, res in isolate(fn, rows, "segments", why):
                    _put_at(segs, sub, res)
                return why, circle.NEWTON_ARCS[0] == n0 and not why

            if later and k_name == K_CHAIN:
                # the chains whose law changed only: each one's plan is its own (its memo,
                # chains.plan_chain_segments, gives the others the plans the last run took)
                seg_cache.drop(k_name)
                seg_failed.update(solve(np.array(ii, int))[0])
                continue
            got, bad = seg_cache.lookup(k_name, ii, plan.T, plan.beta)
            _put_rows(segs, got)
            seg_failed.update(bad)
            todo = _not_in(ii, got, bad)
            del got
            new_bad = None
            hits = None
            if k_name in ROW_KINDS and todo.size:
                # a batch whose plans are each row's own (no Newton step, no failure): the
                # rows of it at the same (T, beta) are reused, the others solved apart, which
                # gives them their own bits too (when that batch also is each row's own)
                hits = seg_cache.lookup_rows(k_name, todo, plan.T, plan.beta)
            if kind_of.batch and todo.size:
                # the last batch missed (but for its hits, kept above): freed before this one is made
                seg_cache.drop(k_name)
            elif todo.size:
                seg_cache.forget_lines(todo)      # (likewise the lines' plans at their old laws)
            if hits:
                new_bad, own_rows = solve(np.array([i for i in todo.tolist() if i not in hits], int))
                if own_rows:
                    _put_rows(segs, hits)
                else:                             # the whole batch solved again: its rows cleared first
                    _clear_at(segs, todo)
                    new_bad = None
            if new_bad is None:
                new_bad, own_rows = solve(todo)
            seg_cache.store(k_name, todo, plan.T, plan.beta, segs, new_bad,
                            own_rows and k_name in ROW_KINDS and circle.rows_invariant())
            seg_failed.update(new_bad)
        _keep_made_plans(plan, strokes, idx[~np.isin(kind, lazy_codes)] if lazy_codes else idx, seg_failed,
                         pin.I_orig)
        plan.remake = remake
        _attach_commands(plan, strokes, pin, rules, cmd0)
        _keep_slowed_corners(plan, strokes, rules, cmd0)
        _lead_out_where_no_command(plan, strokes, pin, rules, seg_cache)
        if own is not None:
            last[0] = _RunMemo(plan, idx_in[own])
        return plan

    if opts.alpha != "auto":
        return run(budget_t)
    return _fit_budget(run, pin, budget_t)


# the kinds whose rows a windowed run (strokes a StoredStrokes) segments a window at a time
# (tests/test_speed52_runs52_rowown.py, test_speed53_arcs53_runs.py: each row's plan its
# own, whatever the batch: lines, chains; arcs and curves where the BLAS gives a row its
# own bits, _CIRCLE_KINDS)
WINDOW_KINDS = (K_LINE, K_ARC, K_CURVE, K_CHAIN)
# kinds solved by laws/circle.py: where the BLAS does not give a row its own bits
# (circle.rows_invariant: the circle laws' products round with the batch), the kind's rows
# are segmented in one batch (Newton's steps are each arc's own: circle._newton_cheb)
_CIRCLE_KINDS = (K_ARC, K_CURVE)
WHOLE_BATCHES = [0]         # such batches so far (a count: benchmarks/win52/runs.py)


LAZY_LINES = True       # tests turn it off: a windowed run keeps every line's plan (the reference)
LAZY_CHAINS = True      # likewise for the chains' plans
SPILL_CHAINS = True     # lazy chains' plans spilled for the rewrite (_ChainSpill); off: remade from their laws
SPILL_LINES = True      # lazy lines' plans spilled for the rewrite (line_spill.LineSpill); off: remade
# windows of rows whose lines a windowed run segments together where they have no classes
# (_line_figures -> _window_figures: a row its own key; with classes, each key once a run):
# plan_segments calls of a window of rows at most (_at_most), not a call a window
LINE_WINDOWS = 4


def _stored_rows(strokes, rows):
    """The strokes of rows (sorted) of a StoredStrokes made of their records alone (its
    store's take) where they are under half of their windows' strokes, not of their windows'
    (a run's lines to segment are a few of each window: gyroid plate, ~3 k lines of 33
    windows, each window ~1.4 ms to load); its windows let go first, written back where due
    (stored_strokes.stored: the store then holds every change).  Else, and of a list, the
    strokes indexed (a window held is not let go and loaded again: the small sample's one
    window, +0.1 MB of peak RSS taken apart)."""
    window = getattr(strokes, "window", None)
    got = None
    if window is not None and rows.size and 2 * rows.size < window * (np.count_nonzero(np.diff(rows // window)) + 1):
        got = stored(strokes)
    return list(map(strokes.__getitem__, rows.tolist())) if got is None else got[0].take(rows)


# curves' rows a windowed run's segments call at most (and a window's strokes at most; the
# candidates' calls hold as many curves' geometry: plan_windows.LEVEL_ROWS).  A call a window
# (_by_windows) was ~70 rows on the rectilinear plate, ~140 on the gyroid, and its fixed costs
# and the windows' loads ~3x a batch's time (plan_curve_segments, _rebuild_geometry: lines57.md)
CURVE_ROWS = 512


def _curve_calls(segments, strokes, plan, rules, profile, n):
    """A windowed run's curves' plans (rows sorted -> a plan a row): segments (plan_curve_
    segments) of the strokes rows in calls of at most n rows, whatever their windows, each
    call's strokes made of their records where sparse (_stored_rows: no window loaded) and
    given their geometry in one batch (_rebuild_geometry: read back where kept).  Every
    row's plan is its own where the BLAS gives a row its own bits (circle.rows_invariant);
    else the rows in one call, as _by_windows solves them."""
    def call(rows):
        sts = _stored_rows(strokes, rows)
        _rebuild_geometry(strokes, rows, np.full(len(sts), C_CURVE, np.int8), profile, sts)
        return segments(sts, plan.T[rows], plan.beta[rows], rules, profile)

    def calls(rows):
        if rows.size > n and not circle.rows_invariant():
            WHOLE_BATCHES[0] += 1
            return call(rows)
        return _at_most(call, n)(rows)
    return calls


def _at_most(fn, n):
    """fn (rows -> a plan a row) made of calls of at most n rows: a window of strokes
    as objects at a time, however many windows' rows are asked."""
    def calls(rows):
        if rows.size <= n:
            return fn(rows)
        out = []
        for a in range(0, rows.size, n):
            out += fn(rows[a:a + n])
        return out
    return calls


def _window_figures(fn, rows, window, plan, strokes, a2_orig, spill=None, line_cls=None):
    """The lines or chains rows (sorted) segmented a window of rows (row // window) at a
    time by fn (rows -> a plan a row), each window's plans judged (_keep_made_plans:
    retime, reason, t_pred, a2_pred on the plan) and then let go: only one window's plans
    live at a time.  The rewrite makes the kept ones again a window at a time (segs_for,
    _PlansAgain): a line's is its row's own at its (T, beta), a chain's is its (T, beta)'s
    from its memo's rows, the same bits (tests/test_speed53_plans53_lazy.py,
    test_speed54_chainplans_lazy.py), or reads them back.  spill: a LineSpill the lines'
    plans are written to under their keys (_line_keys of line_cls), or None."""
    segs = plan.segs
    for part in np.split(rows, np.flatnonzero(np.diff(rows // window)) + 1) if rows.size else ():
        why = {}
        for sub, res in isolate(fn, part, "segments", why):
            _put_at(segs, sub, res)
        if spill is not None:
            spill.put(_take(segs, part), _line_keys(line_cls, part), plan.T[part], plan.beta[part])
        _keep_made_plans(plan, strokes, part, why, a2_orig)
        _clear_at(segs, part)


def _line_figures(fn, rows, window, plan, strokes, a2_orig, line_cls, spill=None):
    """_window_figures of the lines rows (sorted) of a windowed run: with their classes
    (line_cls: segments.line_classes, or None) each (class, T, beta) of the run is
    segmented once, by one row of it (the first), in calls of at most a window of rows, and
    every row is judged on the figures of its key's plan (_KeyFigures, _judge_rows): plan_once
    would have given it that very plan, as the list's one batch plans a key once
    (rectilinear plate: ~39 k lines a run, ~4 k keys, each met in most of its ~50 windows).
    Only a window's plans live at a time, and a few floats a key.  Without classes, a row
    its own key: _window_figures by LINE_WINDOWS windows.  spill: a LineSpill the plans go
    to under their keys (_line_keys), or None."""
    if not rows.size:
        return
    T, beta = plan.T, plan.beta
    if not _keyed(line_cls, T, beta):
        _window_figures(fn, rows, window * LINE_WINDOWS, plan, strokes, a2_orig, spill, line_cls)
        return
    inv, first = column_classes_first([line_cls[rows], T[rows].view(np.int64), beta[rows].view(np.int64)])
    order = np.argsort(first)                   # the keys by their first row
    reps = rows[first[order]]                   # (sorted: rows are)
    place = np.empty_like(order)                # key -> its place in reps
    place[order] = np.arange(order.size)
    del first, order
    segs, figs, why = plan.segs, _KeyFigures(), {}
    for a in range(0, reps.size, window):
        part = reps[a:a + window]
        for sub, res in isolate(fn, part, "segments", why):
            _put_at(segs, sub, res)
        made = _take(segs, part)
        _clear_at(segs, part)
        if spill is not None:
            spill.put(made, line_cls[part], T[part], beta[part])
        figs.add(made, [why.get(i) for i in part.tolist()] if why else None)
        del made
    key = place[inv]                            # each row's key's place in reps
    del inv, place
    figs.done()
    for a in range(0, rows.size, KEEP_ROWS):
        r = rows[a:a + KEEP_ROWS]
        _judge_rows(plan, r, key[a:a + KEEP_ROWS], figs, a2_orig[r])


def _line_keys(line_cls, rows):
    """The classes of the lines rows their plans are kept under (LineSpill's keys: with
    (T, beta)): their line classes, or each row its own (no classes)."""
    return rows if line_cls is None else line_cls[rows]


class _KeyFigures:
    """What _keep_plans reads of the keys' plans (_line_figures), a key's place each: why its
    rows are left as sliced (its segmenting's failure, else its plan's fault verdict; "":
    none, and a row with no plan then does not beat), its plan's int_a2 (NaN where it has a
    why or no plan: it does not beat) and time_t; as arrays once done: not an object a key,
    and the rows judged by array operations (_judge_rows), not by _keep_plans' passes over a
    list of the keys' objects a row."""
    __slots__ = ("why", "a2", "t", "bad")

    def __init__(self):
        # (a2, t: an array an add, joined by done)
        self.why, self.a2, self.t, self.bad = [], [], [], None

    def add(self, made, failed=None):
        """The next keys' plans made (a list; None: none); failed: their segmenting's
        failures (a list, None where it did not fail; None: none failed).  The verdicts not
        made yet are made first in one batch (settle_faults, as _keep_plans makes the list
        path's: "" where seg_fault's would be; the others left to seg_fault below), then
        the usual call (none failed, every one a plan with its verdict "": _verdicts_fine)
        read in two compiled passes, not a seg_fault call and three appends a key
        (rectilinear plate: ~4 k keys a run, three runs; ~2.3 k instructions a key)."""
        if made and not _verdicts_fine(made):
            settle_faults(made)
        if failed is None and made and _verdicts_fine(made):
            fig = objfields.floats(made, ("int_a2", "time_t"))
            if fig is not None:
                self.why += [""] * len(made)
                self.a2.append(fig[:, 0])
                self.t.append(fig[:, 1])
                return
        nan = math.nan
        a2, t = [], []
        for seg, f in zip(made, repeat(None) if failed is None else failed):
            w = f or ("" if seg is None else seg_fault(seg))
            self.why.append(w)
            a2.append(nan if w or seg is None else seg.int_a2)
            t.append(nan if w or seg is None else seg.time_t)
        self.a2.append(np.array(a2, float))
        self.t.append(np.array(t, float))

    def done(self):
        """The figures made arrays (no key added after)."""
        self.a2 = np.concatenate(self.a2) if self.a2 else np.empty(0)
        self.t = np.concatenate(self.t) if self.t else np.empty(0)
        self.bad = np.fromiter(map(bool, self.why), bool, len(self.why))


def _judge_rows(plan, rows, key, figs, a2_orig):
    """_keep_plans(in_place) of the lines rows (no plan held at their rows of plan.segs)
    whose plans are their keys' (key: each row's key's place in figs, a done _KeyFigures):
    a row whose key has a why is left as sliced with it, one whose plan does not beat its
    original (a2_orig: the rows' strokes' int_a2; beats' product and comparison,
    elementwise) with _NOT_BEATING; the others take their key's figures in t_pred and
    a2_pred."""
    a2, bad = figs.a2[key], figs.bad[key]
    keep = a2 < a2_orig * (1.0 - GAIN_TOL_R)       # (a row with a why: its a2 NaN, not kept)
    _left_as_sliced(plan, rows, keep, bad, lambda: map(figs.why.__getitem__, key[bad].tolist()))
    put = rows[keep]
    plan.t_pred[put] = figs.t[key[keep]]
    plan.a2_pred[put] = a2[keep]


def _left_as_sliced(plan, rows, keep, bad, whys):
    """The rows not kept (keep: a mask of rows) left as sliced on plan: those bad (a mask,
    or None: none) with their reasons, whys() (in the rows' order), the others with
    _NOT_BEATING (their plans do not beat their originals)."""
    if bad is not None and bad.any():
        out = rows[bad]
        plan.retime[out] = False
        reason = plan.reason
        for i, why in zip(out.tolist(), whys()):
            reason[i] = why
        lost = ~bad & ~keep
    else:
        lost = ~keep
    if lost.any():
        out = rows[lost]
        plan.retime[out] = False
        plan.reason[out] = _NOT_BEATING


def _split_known(rows, keys, table, missing):
    """(known rows, their keys, their values in table, the other rows, their keys) of rows
    keyed by keys (a list, one a row); missing: table.get's answer for a key it does not
    hold (a sentinel where None is a value).  The rows keep their order on both sides."""
    got = list(map(table.get, keys, repeat(missing)))
    new = np.fromiter(map(partial(is_, missing), got), bool, rows.size)
    if new.all():
        return rows[:0], [], [], rows, keys
    known, new_l = (~new).tolist(), new.tolist()
    return (rows[~new], list(compress(keys, known)), list(compress(got, known)), rows[new],
            list(compress(keys, new_l)))


def _keyed(line_cls, T, beta):
    """Can the lines be keyed by (class, T, beta) (_class_keys)?"""
    return line_cls is not None and T.dtype == beta.dtype == _F64 and T.ndim == beta.ndim == 1


def _class_keys(line_cls, T, beta, rows):
    """The rows' (line class, T, beta) as 24-byte keys (the bits plan_once compares)."""
    k = np.empty((rows.size, 3), np.int64)
    k[:, 0], k[:, 1], k[:, 2] = line_cls[rows], T[rows].view(np.int64), beta[rows].view(np.int64)
    return k.view(_KEY24).ravel().tolist()


_KEY24 = np.dtype((np.void, 24))


def segs_for(plan, rows, strokes):
    """The segment plans of rows (a window the rewrite is about to write) put in plan.segs
    where a windowed run let them go (plan.remake), those made for the window before let
    go; strokes: indexed by row, holding at least those rows' strokes.  Nothing where
    plan.segs holds every plan (the list path)."""
    remake = getattr(plan, "remake", None)
    if remake is not None:
        remake(plan, rows, strokes)


def _are_none(objs):
    """A bool array: which of objs (a list) are None.  Where every one is (the windowed
    rewrite's windows: each row's plan let go by the runs), told by list.count (~10
    instructions an item: None is None before any compare); else their classes read in
    one compiled pass where built (objfields.codes, ~250 instructions an item; np.fromiter
    of is-None's was ~400, ~39 k rows of the rectilinear plate's windowed rewrite)."""
    if type(objs) is list and objs.count(None) == len(objs):
        return np.ones(len(objs), bool)
    got = objfields.codes(objs, "__class__", {type(None): 0}, add=True)
    return got == 0 if got is not None else np.fromiter(map(_IS_NONE, objs), bool, len(objs))


def _ascending(rows):
    """distinct(rows) (rows: a 1-D int array): rows themselves where they are already
    ascending without a repeat (the rewrite's windows, in order of their first lines:
    the rows' order), told by one compare (a sort of a sorted window was ~100
    instructions a row)."""
    if rows.ndim == 1 and (rows.size < 2 or (rows[1:] > rows[:-1]).all()):
        return rows
    return distinct(rows)


def _in_codes(kind, codes):
    """np.isin(kind, codes) where both are small non-negative ints (the KIND_CODEs): a
    lookup in a table of one bool a code (np.isin was ~200 k instructions a window of
    ~3 k rows: its pass a code, in Python); else np.isin itself."""
    codes = np.asarray(codes)
    if (kind.dtype.kind in "iu" and codes.dtype.kind in "iu" and kind.size and codes.size
            and 0 <= int(codes.min()) and int(codes.max()) < _CODES_TOP and 0 <= int(kind.min())
            and int(kind.max()) < _CODES_TOP):
        table = np.zeros(_CODES_TOP, bool)
        table[codes] = True
        return table[kind]
    return np.isin(kind, codes)


_CODES_TOP = 256        # codes _in_codes looks up in a table (the KIND_CODEs: 0 .. 3)


class _PlansAgain:
    """A windowed run's plan.remake: the re-timed lines' and chains' plans it let go
    (_window_figures; codes: the KIND_CODEs it let go), made again for rows as the run made
    them: a line's by _line_segments at the row's (T, beta), its line class, its
    corner_cmd0; a chain's by _chain_plans on the run's own strokes (a StoredStrokes: each
    chain with its memo, ChainMemo, kept past its window, the one the runs asked; the
    rewrite's strokes, the store's, have an empty one, which would plan it from cold: other
    bits), their windows let go once planned.  plan.remade: the rows it put in plan.segs
    last, let go at the next call.  A row whose plan raises now (it did not in the run) is
    left None: the rewrite then keeps its lines, with the reason.  A line of a (class, T,
    beta) the call before made takes that plan (plan.remade_keys: the last window's, by
    key), as plan_once gives a class's rows one plan (rectilinear plate, 1 k windows:
    ~23.5 k plans made without it, ~6.9 k with it; ~3.9 k distinct in the file).  With
    line_spill (line_spill.LineSpill: the runs' line plans) a line's plan is read back where
    its key (class, T, beta) has a record, and made again only where not."""
    __slots__ = ("kind", "line_cls", "cmd0", "rules", "profile", "codes", "chain_strokes", "spill", "line_spill")

    def __init__(self, kind, line_cls, cmd0, rules, profile, codes, chain_strokes, spill=None, line_spill=None):
        self.kind, self.line_cls, self.cmd0, self.rules = kind, line_cls, cmd0, rules
        self.profile, self.codes, self.chain_strokes, self.spill = profile, codes, chain_strokes, spill
        self.line_spill = line_spill

    def __call__(self, plan, rows, strokes):
        segs = plan.segs
        old = getattr(plan, "remade", None)
        if old is not None:
            _clear_at(segs, old)
        rows = _ascending(np.asarray(rows, np.int64))
        rows = rows[_in_codes(self.kind[rows], self.codes) & plan.retime[rows]]
        if rows.size:
            rows = rows[_are_none(_take(segs, rows))]
        kind = self.kind[rows]
        chain_rows = rows[kind == C_CHAIN]
        if chain_rows.size and self.spill is not None:
            # (the plans the runs spilled for these rows' (T, beta): read back, not made again)
            got, plans, chain_rows = self.spill.take(chain_rows, plan.T[chain_rows], plan.beta[chain_rows])
            _put_at(segs, got, plans)
        if chain_rows.size:
            src = self.chain_strokes
            for sub, res in isolate(partial(_chain_plans, src, plan, self.rules, self.profile), chain_rows,
                                    "segments", {}):
                _put_at(segs, sub, res)
            src.let_go()            # (its windows' strokes not held past the plans made of them)
        if C_LINE in self.codes:
            self._lines(plan, rows[kind == C_LINE], strokes)
        else:
            plan.remade_keys = None
        plan.remade = rows

    def _lines(self, plan, rows, strokes):
        """The lines rows' plans read back from the runs' records, or made again (a class
        met in the call before: its plan)."""
        segs = plan.segs
        if self.line_spill is not None and rows.size:
            got, plans, rows = self.line_spill.take(rows, _line_keys(self.line_cls, rows), plan.T[rows],
                                                    plan.beta[rows])
            _put_at(segs, got, plans)
        cls = self.line_cls
        keys, last, now = None, getattr(plan, "remade_keys", None) or {}, {}
        todo = rows
        if _keyed(cls, plan.T, plan.beta) and rows.size:
            keys = _class_keys(cls, plan.T, plan.beta, rows)
            old, old_keys, seg_l, todo, keys = _split_known(rows, keys, last, None)
            _put_at(segs, old, seg_l)
            now.update(zip(old_keys, seg_l))
        plan.remade_keys = last = None       # (the last window's plans not held while these are made)

        def make(r):
            return _line_segments(list(map(strokes.__getitem__, r.tolist())), plan.T[r], plan.beta[r], self.rules,
                                  None if cls is None else cls[r], self.cmd0[r])
        for sub, res in isolate(make, todo, "segments", {}):
            _put_at(segs, sub, res)
        if keys is not None:
            now.update((k, seg) for k, seg in zip(keys, _take(segs, todo)) if seg is not None)
        plan.remade_keys = now


# a windowed run's chain rows are planned a window of rows at a time (_window_figures), but
# windows with few of them together, up to window // CHAIN_CALL_SHARE rows a call
# (_chain_calls): a later run re-plans only the chains whose law changed (gyroid plate at
# 1 k: ~900 in 29 windows, ~30 a call), and each call pays its set-up by segment count
# (replay, finishing, checks, the spill's write); a first run's windows (~450-800 chains
# each there) are left as they are, so their peak is not raised
CHAIN_CALL_SHARE = 4


def _chain_calls(rows, window):
    """rows (sorted) cut into the parts a windowed run plans its chains in: a window of rows
    (row // window) each, but consecutive windows joined while the part has at most
    window // CHAIN_CALL_SHARE rows (a window with more stays a part of its own)."""
    if not rows.size:
        return []
    cut = np.flatnonzero(np.diff(rows // window)) + 1
    most = max(1, int(window / CHAIN_CALL_SHARE))
    ends, size = [], np.diff(np.r_[0, cut, rows.size]).tolist()
    at, n = 0, 0
    for k in size:
        if n and n + k > most:
            ends.append(at)
            n = 0
        at += k
        n += k
    return np.split(rows, ends)


def _chain_plans(strokes, plan, rules, profile, rows, spill=None):
    """The chains rows' plans at their (T, beta) of plan, their curve geometry made first
    (as the windowed run makes a window's: _rebuild_geometry), no memo keeping its plan
    (plan_chain_segments' remember: a windowed run's chains keep their figures only).
    spill: a _ChainSpill the plans are written to (the run's, for the rewrite), or None."""
    sts = _chain_strokes(strokes, rows)
    _rebuild_geometry(strokes, rows, np.full(len(sts), C_CHAIN), profile, sts)
    T, beta = plan.T[rows], plan.beta[rows]
    # (spilled: the rewrite reads the plans back, no chain keeps the law it chose for it;
    # the replayed plans' blocks handed over as made)
    blocks = None if spill is None else []
    plans = chains.plan_chain_segments(sts, T, beta, rules, profile, remember=False, keep_laws=spill is None,
                                       blocks=blocks)
    if spill is not None:
        spill.put(rows, T, beta, plans, blocks)
    return plans


def _chain_strokes(strokes, rows):
    """The strokes of the chains rows (sorted).  Of a StoredStrokes whose kept fields
    (chain_T: the memos, whose state the runs' bits depend on) it holds for every row
    (StoredStrokes.kept_at), made of their records alone with those objects put in (its
    store's take: the same strokes a window's load makes), not their windows loaded: a
    run's chains are ~half of a window's rows (gyroid plate: 29 loads for 16.4 k chains), a
    later run's a few (29 loads for ~850).  A memo is changed in place by the plans (never
    replaced), so the kept one stays the row's.  Else (a list, or a memo not kept yet) the
    strokes indexed."""
    over = strokes.kept_at(rows) if isinstance(strokes, StoredStrokes) else None
    if over is not None:
        return strokes.store.take(rows, over)
    return list(map(strokes.__getitem__, rows.tolist()))


# a spilled plan's record: T, beta, time_t, int_a2, its type (_SPILL_TYPES' index), 1.0 where
# its fault verdict was made "" (settle_faults' checks passed) else 0.0 (None: seg_fault makes
# it when asked), then the knots s (n + 1), speeds v (n + 1), accelerations (n) and feeds (n)
# of its n segments
_SPILL_HEAD = 6
_SPILL_TYPES = (RowPlan, SegmentPlan)
_SPILL_N = np.iinfo(np.uint16).max      # segments a spilled plan has at most (_ChainSpill.nseg)
_SPILL_END = np.iinfo(np.int32).max     # the doubles the records take at most (_ChainSpill.at)


# doubles between two records _ChainSpill._read reads in one pread at most (the gaps read are
# held with the window's plans, views of the buffer: 4 kB a run at most)
CHAIN_GAP = 512


def _spill_len(n):
    """The doubles of the record of a plan of n segments."""
    return _SPILL_HEAD + 4 * n + 2


class _ChainSpill(SpillFile):
    """The chains' plans a windowed run made (_chain_plans), written as they are made to an
    unnamed temporary file, a record of doubles a plan (_SPILL_HEAD), and read back by the
    rewrite's remake (_PlansAgain) for the rows whose (T, beta) is the one their record was
    made for: the same numbers, not made again (a chain's plan at a (T, beta) is its memo's,
    the same bits each time it is made: test_speed54_chainplans_lazy.py), and without the
    chains' strokes, their curve geometry or their laws (the gyroid plate: ~16 k chains
    re-planned by the rewrite before, benchmarks/replay55.md).  A row's latest record is
    the one kept (a later run's plan of the row replaces it); a row with none, or with
    another (T, beta), is re-planned by the caller, as is every row once the records would
    pass _SPILL_END doubles.  Held: 6 bytes a row; the records' bytes (~11 MB on the gyroid
    plate) are the file's, not the process'."""

    def __init__(self, n_rows, fh):
        super().__init__(fh)
        # (6 bytes a row, held from the runs to the rewrite, their peak: ~0.2 MB on the gyroid plate)
        self.at = np.full(n_rows, -1, np.int32)     # a row's record: its first double's index in the file
        self.nseg = np.zeros(n_rows, np.uint16)     # its plan's segments

    @classmethod
    def make(cls, n_rows, folder=None):
        """A spill over n_rows rows in folder (None: the temporary folder), or None where no
        file can be made there."""
        fh = SpillFile.open(folder)
        return None if fh is None else cls(n_rows, fh)

    def put(self, rows, T, beta, plans, made=None):
        """The plans (a list, rows' order; None: no plan) made for rows at (T, beta) written,
        those of a kind the records do not hold (another type or shape, a junction command)
        left out; a failed write leaves every row without a record.  made: the RowPlans'
        blocks as plan_chain_segments made them (its blocks), or None: the plans grouped
        by their blocks here (_row_plan_blocks)."""
        if self.fh is None:
            return
        T, beta = np.asarray(T, float), np.asarray(beta, float)
        blocks, rest = _row_plan_blocks(plans) if made is None else _made_blocks(plans, made)
        parts, qs, ns = _blocks_records(T, beta, plans, blocks) if blocks else ([], [], [])
        for q in rest:
            got = _spill_arrays(plans[q])
            if got is not None:
                head, arrs = got
                head[0], head[1] = T[q], beta[q]
                parts += [head] + arrs
                qs.append(np.array([q], np.int64))
                ns.append(np.array([arrs[2].size], np.int64))
        if not qs:
            return
        # (the blocks' records alone: their one array as it is)
        buf, ns, qs = (parts[0], ns[0], qs[0]) if len(parts) == 1 else map(np.concatenate, (parts, ns, qs))
        lens = _spill_len(ns)
        end = self.append(buf, _SPILL_END)      # (indices past int32: no more records, all made again)
        if end is None:
            return
        ok = rows[qs]
        self.at[ok], self.nseg[ok] = end + np.cumsum(lens) - lens, ns

    def take(self, rows, T, beta):
        """(the rows of rows (sorted) with a record made at their (T, beta), their plans;
        the other rows)."""
        at = self.at[rows] if self.fh is not None else np.full(rows.size, -1, np.int64)
        has = at >= 0
        if not has.any():
            return rows[:0], [], rows
        hat, hn = at[has].astype(np.int64), self.nseg[rows[has]].astype(np.int64)
        try:
            buf, start = self._read(hat, _spill_len(hn))
        except OSError:             # (the records lost: every row made again)
            self.close()
            return rows[:0], [], rows
        # a record is the row's where it was made for the row's (T, beta), bit for bit (the
        # heads of all of them compared at once)
        bits = buf.view(np.int64)
        same = ((bits[start] == np.asarray(T, float)[has].view(np.int64))
                & (bits[start + 1] == np.asarray(beta, float)[has].view(np.int64)))
        if not same.all():
            start, hn = start[same], hn[same]
        plans = _spill_plans(buf, start, _record_blocks(buf, start, hn)) if start.size else []
        has[has] = same
        return rows[has], plans, rows[~has]

    def _read(self, at, lens):
        """The records at at (doubles from the file's start, lens long) read: (one array of
        their doubles, each one's first index there); records at most CHAIN_GAP doubles
        apart in one read."""
        o = np.argsort(at, kind="stable")
        a, z = at[o], at[o] + lens[o]
        # (with what lies between: the gyroid plate's rewrite, ~600 preads of runs of
        # consecutive records -> ~200)
        buf, start_o = self.read_runs(a, z, np.flatnonzero(a[1:] > z[:-1] + CHAIN_GAP) + 1, "chain plans'")
        start = np.empty(at.size, np.int64)
        start[o] = start_o
        return buf, start


def _record_blocks(buf, start, ns):
    """The records (first doubles start in buf, of plans of ns segments) as blocks of
    consecutive records of one segment count: [(their indices, the block (a view of buf:
    not a copy of the records, nor an index array as large), n)]; a block's records are
    written together (_ChainSpill.put: a finishing block's plans one after the other)."""
    # (lexsort's order by (ns, start) as one int64 key: the starts are distinct, below
    # buf.size; one stable argsort (timsort: the keys come in runs), not lexsort's two)
    o = np.argsort(ns.astype(np.int64) * (buf.size + 1) + start, kind="stable")
    no, so = ns[o], start[o]
    lens = _spill_len(no)
    cut = np.flatnonzero((no[1:] != no[:-1]) | (so[1:] != so[:-1] + lens[:-1])) + 1
    firsts = np.r_[0, cut]
    out = []
    # (each block's n, length and start as Python ints at once: not numpy scalars a block)
    for a, z, n, L, s0 in zip(firsts.tolist(), cut.tolist() + [o.size], no[firsts].tolist(), lens[firsts].tolist(),
                              so[firsts].tolist()):
        out.append((o[a:z], buf[s0:s0 + (z - a) * L].reshape(z - a, L), n))
    return out


def _row_plan_blocks(plans):
    """plans' RowPlans of the planned law with no junction command, rows of blocks V, A, F
    and knots made of their strokes' ends (chains._replay's and _again_plans'), by their
    blocks: ([((V, A, F), their places in plans, their rows, their ends)], the other
    places (not None))."""
    by, rest = {}, []
    for q, p in enumerate(plans):
        if p is None:
            continue
        if (type(p) is RowPlan and type(p._row) is int and type(p._s) is array and p.shape == "law"
                and p.first_cmds is None):
            V = p._v
            got = by.get(id(V))
            if got is not None:         # (V is that block's: its type checked once, when it was met)
                if got[0][1] is p._accel and got[0][2] is p._feed:
                    got[1].append(q)
                    got[2].append(p._row)
                    got[3].append(p._s)
                    continue
            elif (type(V) is np.ndarray and V.dtype == _F64 and V.ndim == 2 and type(p._accel) is np.ndarray
                  and type(p._feed) is np.ndarray):
                by[id(V)] = ((V, p._accel, p._feed), [q], [p._row], [p._s])
                continue
        rest.append(q)
    out = []
    for (V, A, F), ii, rr, ends in by.values():
        n = A.shape[1]
        if (A.dtype == F.dtype == _F64 and V.shape[1] == n + 1 and A.shape == F.shape and n <= _SPILL_N
                and all(e.typecode == "d" and len(e) == n for e in ends)):
            out.append(((V, A, F), np.array(ii, np.int64), np.array(rr, np.intp), ends))
        else:
            rest += ii
    return out, rest


def _made_blocks(plans, made):
    """_row_plan_blocks' answer for plans, the blocks made given (plan_chain_segments'
    blocks: (places, V, A, F, ends), each place's plan RowPlan(ends[i], V, A, F, i) as the
    replay made it, unchanged since: not checked a plan) where the records hold them (the
    blocks' types and shapes checked a block); the other plans grouped by _row_plan_blocks."""
    out, covered = [], np.zeros(len(plans), bool)
    for ii, V, A, F, ends in made:
        if _block_fits(V, A, F):
            # (every row of the block, in order: taken as it is)
            out.append(((V, A, F), ii, slice(None) if V.shape[0] == ii.size else np.arange(ii.size, dtype=np.intp),
                        ends))
            covered[ii] = True
    if covered.all():
        return out, []
    others = np.flatnonzero(~covered)
    more, rest = _row_plan_blocks(_take(plans, others))
    out += [(b, others[ii], rr, ends) for b, ii, rr, ends in more]
    return out, others[rest].tolist() if rest else []


def _block_fits(V, A, F):
    """Do blocks V, A, F (knot speeds, accelerations, feeds of plans of n segments) have the
    records' types and shapes (_row_plan_blocks' checks of a block)?"""
    return (type(V) is type(A) is type(F) is np.ndarray and V.dtype == A.dtype == F.dtype == _F64 and V.ndim == 2
            and A.ndim == 2 and V.shape[1] == A.shape[1] + 1 and A.shape == F.shape and V.shape[0] == A.shape[0]
            and A.shape[1] <= _SPILL_N)


def _blocks_records(T, beta, plans, blocks):
    """The records of the RowPlans of blocks (_row_plan_blocks) of plans made at (T, beta)
    (by place in plans): ([the blocks' records, flat, in one array], [their places],
    [their segment counts]).  The heads of every block's plans (and each record's first
    knot, 0) are made in one pass (their figures read by objfields where built) and put in
    one step, their knots (their strokes' ends) of one join; a block then takes three row
    copies and its ends (a block's own set-up was ~20 us, ~1 k blocks a windowed gyroid
    run; its rows in order, _made_blocks' slice: the block itself, not a gathered copy)."""
    ii = np.concatenate([b[1] for b in blocks])
    bp = _take(plans, ii)
    m = ii.size
    ns = np.repeat([b[0][1].shape[1] for b in blocks], [b[1].size for b in blocks])
    lens = _spill_len(ns)
    at = np.cumsum(lens) - lens                 # each record's first double
    k = _SPILL_HEAD
    H = np.empty((m, k + 1))
    H[:, 0], H[:, 1] = T[ii], beta[ii]
    plan_heads(bp, H[:, 2:6])           # (figures, _SPILL_TYPES' RowPlan, verdicts)
    H[:, k] = 0.0                       # (the first knot)
    buf = np.empty(int(lens.sum()))
    buf[at[:, None] + np.arange(k + 1)] = H
    del H
    ends = np.frombuffer(b"".join([b"".join(b[3]) for b in blocks]), float)
    at, a, e = at.tolist(), 0, 0
    for (V, A, F), q, rr, _ in blocks:
        mb, n = q.size, A.shape[1]
        L = k + 4 * n + 2                       # (_spill_len(n))
        # (the knots, speeds, accelerations and feeds put by one concatenate into the records'
        # rows: one numpy call a block, not four assignments)
        np.concatenate((ends[e:e + mb * n].reshape(mb, n), V[rr], A[rr], F[rr]), axis=1,
                       out=buf[at[a]:at[a] + mb * L].reshape(mb, L)[:, k + 1:])
        a, e = a + mb, e + mb * n
    return [buf], [ii], [ns]


def _spill_arrays(p):
    """(a record's head with p's figures, [s, v, accel, feed]) of plan p, or None where p
    is not one the records hold: a RowPlan or SegmentPlan of the planned law, no junction
    command, four 1-D float64 arrays of n + 1, n + 1, n, n numbers."""
    arrs = plan_arrays(p, ("law",), _SPILL_N)
    if arrs is None:
        return None
    return np.array([0.0, 0.0, p.time_t, p.int_a2, _SPILL_TYPES.index(type(p)), _fine_flag(p)]), arrs


def _fine_flag(p):
    """1.0 where plan p's fault verdict is "" (made: its checks passed), else 0.0."""
    return 1.0 if p.fault == "" else 0.0


def _spill_plans(buf, start, blocks):
    """The plans of the records of buf at start, as blocks (_record_blocks; _SPILL_HEAD's
    layout), in start's order, each with its verdict "" where the record's plan had it (the same
    numbers: the checks pass again; the plans made again had it from settle_faults' checks,
    chains._replay)."""
    return block_plans(buf, start, blocks, _SPILL_HEAD, (2, 3, 4, 5, None))


def _by_windows(fn, window, circle_law=False, before=None):
    """fn (rows -> a plan a row, rows sorted) made of one call a window of rows (row //
    window): only that window's strokes are objects at a time.  circle_law: where the BLAS
    does not give rows their own bits, the rows in one call: the plans a single batch
    gives.  before(rows): called before fn on the same rows (the curve geometry of a
    window's strokes: _rebuild_geometry, as the list path makes it for a run's rows, the
    strokes loaded without it)."""
    def call(rows):
        if before is not None:
            before(rows)
        return fn(rows)

    def by_windows(rows):
        cut = np.flatnonzero(np.diff(rows // window)) + 1
        if not cut.size:
            return call(rows)
        if circle_law and not circle.rows_invariant():
            WHOLE_BATCHES[0] += 1
            return call(rows)
        out = []
        for part in np.split(rows, cut):
            out += call(part)
        return out
    return by_windows


_NOT_BEATING = "segments would not beat the original"
REUSE_RUNS = True       # tests turn it off: every budget run segments all its strokes (the reference)
# rows whose plans _put_at and _copy_at put at once: in _RunMemo.put_same the int objects
# of two lists of all ~38 k rows were 3.1 MB, the moment of the rectilinear plate's
# planning peak (a later run's start)
PUT_ROWS = 4096


class _RunMemo:
    """A budget run's outcome for its re-timed line and chain strokes `rows` (sorted):
    their law (T, beta) and what the segment stage made of it (retime, reason, segs,
    t_pred, a2_pred).  A line's segment plan is its row's own at its (T, beta) (the
    SegmentCache hands back the one it made), a chain's too (its memo: chains.
    plan_chain_segments), and _keep_plans decides row by row: a later run whose row keeps
    the bits of its (T, beta) would get this outcome again.  put_same gives it, and the
    run segments only the others (rectilinear plate: its third run re-segmented ~0 of
    41 k strokes but passed over all of them, ~0.06 s)."""
    __slots__ = ("rows", "T", "beta", "retime", "reason", "segs", "t_pred", "a2_pred")

    def __init__(self, plan, rows):
        self.rows = rows
        self.T, self.beta = plan.T[rows], plan.beta[rows]
        self.retime, self.reason = plan.retime[rows], plan.reason[rows]
        self.segs = _take(plan.segs, rows)
        self.t_pred, self.a2_pred = plan.t_pred[rows], plan.a2_pred[rows]

    def put_same(self, plan, idx, own):
        """The outcome kept here put on plan for the rows of idx (re-timed, sorted) where
        own (a mask over idx: lines and chains) whose T and beta are this run's bit for bit;
        returns the other rows of idx, in order."""
        n = plan.T.size
        pos = np.full(n, -1, np.intp)
        pos[self.rows] = np.arange(self.rows.size)
        rows = idx[own]
        p = pos[rows]
        hit = p >= 0
        rows, p = rows[hit], p[hit]
        same = ((plan.T[rows].view(np.int64) == self.T[p].view(np.int64))
                & (plan.beta[rows].view(np.int64) == self.beta[p].view(np.int64)))
        u, pu = rows[same], p[same]
        if not u.size:
            return idx
        plan.retime[u] = self.retime[pu]
        plan.reason[u] = self.reason[pu]
        plan.t_pred[u] = self.t_pred[pu]
        plan.a2_pred[u] = self.a2_pred[pu]
        _copy_at(plan.segs, u, self.segs, pu)
        done = np.zeros(n, bool)
        done[u] = True
        return idx[~done[idx]]
REPEAT_R = 0.35         # _lines_repeat: at most this share of the lines distinct


def _corner_cmd0(strokes):
    """The strokes' corner_cmd0 as a bool array: a StoredStrokes' from its store's column
    (no window loaded; a record of another type than a bool or an int read as the list's)."""
    if isinstance(strokes, StoredStrokes):
        try:
            return strokes.column("corner_cmd0") != 0
        except TypeError:
            pass
    cmd0 = objfields.float_col(strokes, "corner_cmd0")     # (True / False: 1.0 / 0.0)
    return np.fromiter(map(_CORNER_CMD0, strokes), bool, len(strokes)) if cmd0 is None else cmd0 != 0.0


def _line_classes(strokes, rows, window):
    """segments.line_classes of the strokes rows: windowed (window not None), read from the
    records of the store that keeps them where it can (segments.stored_line_classes: no
    window loaded; its held windows let go, written back where due, first), else a window
    at a time (StrokeRows)."""
    if window is None:
        return line_classes(list(map(strokes.__getitem__, rows.tolist())))
    got = stored(strokes)
    cls = None if got is None else stored_line_classes(got[0], rows)
    return line_classes(StrokeRows(strokes, rows)) if cls is None else cls


def _lines_repeat(pin, rows):
    """Do enough of the lines rows repeat another one for segments.line_classes (reading
    ~16 fields of every line, ~1.4 µs a line) to pay: at most REPEAT_R of them distinct in
    (L, v0, v1, T_orig) as plan_inputs read them (a guess only: the classes are made
    of the strokes' own fields).  The rectilinear plate's 48.6 k lines: 13 % distinct (its
    budget runs then segment ~6 k lines, not ~68 k); the gyroid plate's 13.8 k: 49 %."""
    if rows.size < 2:
        return False
    # asked for the same lines by the candidates (their step, then each chunk) and the plan
    # runs: the last answer kept on pin, by a digest of the rows' int64 bytes (the bytes
    # themselves were 0.37 MB held from the candidates to the summary, rectilinear plate)
    key = _rows_digest(rows)
    memo = getattr(pin, "lines_repeat_memo", None)
    if memo is not None and memo[0] == key:
        return memo[1]
    cols = [np.asarray(x[rows], float).view(np.int64) for x in (pin.L, pin.v0, pin.v1, pin.T_orig)]
    got = bool(column_classes_first(cols)[1].size <= REPEAT_R * rows.size)
    pin.lines_repeat_memo = (key, got)
    return got


def _rows_digest(rows):
    """A key of rows (an int array) as its int64 bytes: their count and CRC-32, read from the
    array's buffer (no copy where the rows are contiguous int64 already; SHA-256 cost ~15 M
    instructions a call on the rectilinear plate).  Two sets of rows may share a key: the
    answer _lines_repeat keeps only picks between paths that make the same tables and plans
    (a guess, as its docstring says), so a collision could cost time, never a bit."""
    a = np.ascontiguousarray(rows, np.int64)
    return a.size, binascii.crc32(a)


def _put_rows(segs, got):
    """segs[i] = plan for each {i: plan} of got (segs: a list by row; i: ints), in one
    compiled pass (objfields.put_at) where the core is built.  (The loops here and below
    store through CPython's list-item opcode, ~190 instructions a row with the iteration;
    deque(map(segs.__setitem__, ...)) called the method wrapper, ~570.)"""
    n = len(got)
    keys, plans = iter(got), iter(got.values())
    for a in range(0, n, PUT_ROWS):       # (rows and plans of all ~40 k hits at once: +0.9 MB at the rectilinear plate's peak)
        m = min(PUT_ROWS, n - a)
        if not objfields.put_at(segs, np.fromiter(keys, np.intp, m), list(islice(plans, m))):
            break                         # (the first chunk only: every chunk's types are the same)
    else:
        return
    for i, seg in got.items():
        segs[i] = seg


def _clear_at(segs, rows):
    """segs[i] = None for i in rows (an int array)."""
    if not objfields.fill_at(segs, rows, None):
        _put_at(segs, rows, repeat(None))


def _put_at(segs, rows, plans):
    """segs[i] = plan for i, plan in zip(rows, plans) (rows: an int array, plans: an
    iterable as long): where plans is a list as long, in one compiled pass (objfields.put_at),
    else PUT_ROWS rows at a time: their int objects are not all made at once (~41 k rows,
    1.2 MB of them, a budget run's lines on the rectilinear plate)."""
    if type(plans) is list and objfields.put_at(segs, rows, plans):
        return
    it = iter(plans)
    for a in range(0, rows.size, PUT_ROWS):
        for i, seg in zip(rows[a:a + PUT_ROWS].tolist(), it):      # (zip stops at the rows' end)
            segs[i] = seg


def _copy_at(dst, dst_rows, src, src_rows):
    """dst[i] = src[j] for i, j in zip(dst_rows, src_rows) (int arrays of one size; dst,
    src: lists), in one compiled pass, else PUT_ROWS rows at a time, as _put_at."""
    if objfields.put_at(dst, dst_rows, src, src_rows):
        return
    for a in range(0, dst_rows.size, PUT_ROWS):
        b = a + PUT_ROWS
        for i, j in zip(dst_rows[a:b].tolist(), src_rows[a:b].tolist()):
            dst[i] = src[j]


KEEP_ROWS = 8192        # rows _keep_made_plans hands _keep_plans at once


def _keep_made_plans(plan, strokes, idx, seg_failed, a2_orig):
    """_keep_plans of the plans a run wrote in plan.segs for the rows idx (sorted), which
    are None there again unless kept: KEEP_ROWS rows at a time, each row decided on its
    own (the int objects of idx's list, twice, were ~3.3 MB, the moment of the
    rectilinear plate's planning peak).  a2_orig: every stroke's int_a2 (pin.I_orig).
    The plans stay where they are and only the rows not kept are set to None (_keep_plans'
    in_place): every row set to None, then the kept ones put back, was two list writes a
    row through a method wrapper (~1.1 k instructions; ~80 M on the rectilinear plate)."""
    segs = plan.segs
    for a in range(0, idx.size, KEEP_ROWS):
        rows = idx[a:a + KEEP_ROWS]
        rows_l = rows.tolist()
        seg_l = _take(segs, rows)
        _keep_plans(plan, strokes, rows, seg_l, seg_failed, rows_l, a2_orig[rows], in_place=True)


def _take(seq, rows):
    """[seq[i] for i in rows] (seq a list, rows an int array): in one compiled pass
    (objfields.take, ~10 instructions an item) where the core is built, else _items."""
    got = objfields.take(seq, rows)
    return got if got is not None else _items(seq, rows.tolist())


def _items(seq, at):
    """[seq[i] for i in at] (at: a list of ints) by one itemgetter (~150 instructions an
    item; the comprehension ~200, list(map(seq.__getitem__, at)) ~240)."""
    if len(at) < 2:             # (itemgetter of one item gives it, not a tuple)
        return [seq[i] for i in at]
    return list(itemgetter(*at)(seq))


def _keep_plans(plan, strokes, idx, seg_l, seg_failed, idx_l=None, a2_orig=None, in_place=False):
    """The segment plans seg_l (a list: row idx[q]'s plan, or None) of the rows idx (an int array) put on the plan:
    a row whose segmenting failed (seg_failed: its reason), whose plan has a fault
    (seg_fault), has none, or does not beat its original (beats) is left as sliced with
    its reason; the others are put in plan.segs with their figures in t_pred and a2_pred.

    Row by row, the same as a loop over idx asking each row in turn (tests/
    test_speed26_linec_keep.py keeps that loop), made as a few passes over the rows'
    lists and arrays (~41 k rows a budget run on the rectilinear plate, three runs: the
    loop's ~1 µs a row was ~0.1 s of its planning): the faults in one list, beats on
    arrays (the same product and comparison of doubles), the kept rows put at once.
    idx_l: idx.tolist(), when the caller has it; a2_orig: the rows' strokes' int_a2 (a
    float array) when the caller has them (pin.I_orig, read once: their ~41 k attribute
    reads a run were ~5 ms).  in_place: seg_l's plans are at their rows of plan.segs
    already (_keep_made_plans): the kept ones stay, the others are set to None."""
    if idx_l is None:
        idx_l = idx.tolist()
    n = len(seg_l)
    # the common case: every row has a plan and every plan its verdict "" (settle_faults),
    # found in one compiled pass where it holds (a later run's plans mostly have theirs)
    fine = not seg_failed and _verdicts_fine(seg_l)
    if not fine:
        try:                    # every row a plan with a verdict slot (else AttributeError)
            why_l = list(map(_FAULT, seg_l))
        except AttributeError:
            settle_faults(seg_l)
        else:
            if why_l.count(None):   # settle_faults of the plans with no verdict yet (it skips the others)
                settle_faults(list(compress(seg_l, map(_IS_NONE, why_l))))
        fine = not seg_failed and _verdicts_fine(seg_l)
    fig = None                  # the plans' (int_a2, time_t), where read in one pass
    if fine:
        # the common case: every row has a plan and every plan its verdict "" (settle_faults)
        bad_why = None
        fig = objfields.floats(seg_l, ("int_a2", "time_t"))
        a2 = np.fromiter(map(_INT_A2, seg_l), float, n) if fig is None else fig[:, 0]
    else:
        # seg_fault(seg): its verdict kept on the plan (settle_faults set it on most), else made
        if seg_failed:
            fail = seg_failed.get
            why_l = [fail(i) or ("" if seg is None else seg_fault(seg)) for i, seg in zip(idx_l, seg_l)]
        else:
            why_l = ["" if seg is None else f if (f := getattr(seg, "fault", None)) is not None else seg_fault(seg)
                     for seg in seg_l]
        # the figures of the fault-free plans only (the others' are not read: they may be anything)
        nan = math.nan
        a2 = np.array([nan if why or seg is None else seg.int_a2 for seg, why in zip(seg_l, why_l)], float)
        bad_why = np.fromiter(map(bool, why_l), bool, n)
    if a2_orig is None:
        a2_orig = np.fromiter(map(_INT_A2, map(strokes.__getitem__, idx_l)), float, n)
    # beats(a2_plan, a2_orig) elementwise (the same product and comparison of doubles); a
    # plan that is None has a2 = nan: it does not beat
    keep = a2 < a2_orig * (1.0 - GAIN_TOL_R)
    if bad_why is not None:
        keep &= ~bad_why
    _left_as_sliced(plan, idx, keep, bad_why, lambda: [why for why in why_l if why])
    if keep.all():
        put, put_l, kept, a2_kept = idx, idx_l, seg_l, a2
        t_kept = None if fig is None else fig[:, 1]
    else:
        k = np.flatnonzero(keep)
        put = idx[k]
        put_l, kept, a2_kept = None if in_place else put.tolist(), list(map(seg_l.__getitem__, k.tolist())), a2[k]
        t_kept = None if fig is None else fig[k, 1]
        if in_place:
            segs = plan.segs
            for i in idx[~keep].tolist():
                segs[i] = None
    if not kept:
        return
    if not in_place:
        segs = plan.segs
        for i, seg in zip(put_l, kept):
            segs[i] = seg
    plan.t_pred[put] = np.fromiter(map(_TIME_T, kept), float, len(kept)) if t_kept is None else t_kept
    plan.a2_pred[put] = a2_kept


_FAULT, _INT_A2, _TIME_T = attrgetter("fault"), attrgetter("int_a2"), attrgetter("time_t")
_FINE = {"": 0}             # _verdicts_fine's codes: the one verdict it accepts


def _verdicts_fine(seg_l):
    """Is every item of the list seg_l an object whose verdict (its fault) is "" (so not
    None: a plan)?  By objfields.codes' compiled pass (~40 instructions a plan) where the
    core is built, else as list(map(_FAULT, seg_l)).count("") == len(seg_l) (~280)."""
    if objfields.codes(seg_l, "fault", _FINE) is not None:
        return True
    if type(seg_l) is list and getattr(objfields, "_CODES", None) is not None:
        return False            # (the pass found a verdict not "", or none)
    try:
        return list(map(_FAULT, seg_l)).count("") == len(seg_l)
    except AttributeError:
        return False
_IS_NONE = partial(is_, None)   # x is None
_IS_NOT_NONE = partial(is_not, None)
_CORNER_CMD0 = attrgetter("corner_cmd0")


def _not_in(ii, got, bad):
    """The rows of ii (in order, an int array) that are keys of neither dict (their keys
    are rows of ii: SegmentCache.lookup's answers), as a new int array (np.array copies:
    not through a list, ~20 M instructions on the rectilinear plate)."""
    if not got and not bad:
        return np.array(ii, int)
    if ii.size == 0:
        return np.array([], int)
    keys = np.fromiter(list(got) + list(bad), np.int64, len(got) + len(bad))
    # (a mask over the rows, not np.isin's sorts: ~20 ms a budget run on the rectilinear plate)
    hit = np.zeros(max(int(ii.max()), int(keys.max())) + 1, bool)
    hit[keys] = True
    return np.array(ii[~hit[ii]], int)


def _rebuild_geometry(strokes, idx, kind, profile, sts=None):
    """The curve geometry of the strokes idx to segment that has none (the pipeline may
    drop it between passes: ~17 MB on the gyroid plate), made in one batch as
    plan_inputs made it (the same bits), not stroke by stroke (~2 s on that plate).  A
    stroke whose geometry raises makes it where isolate() catches it, in its kind's
    segments.  kind: the KIND_CODEs of the strokes idx; sts: those strokes, if the caller
    read them.  A chain's κ is not made (it never reads it: made if read, _Blk.make_kappa).
    A StoredStrokes' kept geometry (its geoms: plan_inputs', geom_keep) is given back
    first, without κ at the vertices (the candidates, its one reader, are made)."""
    geoms = getattr(strokes, "geoms", None)
    made = False
    for k, chain in ((C_CURVE, False), (C_CHAIN, True)):
        is_k = kind == k
        if not is_k.any():
            continue
        rows = idx[is_k]
        # (each stroke read once: a windowed run's strokes are a StoredStrokes, ~117 calls)
        ksts = list(map(strokes.__getitem__, rows.tolist())) if sts is None else list(compress(sts, is_k.tolist()))
        if geoms is not None:
            geoms.give(rows, ksts)
        todo = [st for st in ksts if st.curv is None]
        if todo:
            made = True
            try:
                curves.build_geoms(todo, profile, jerk1=chain, kappa=not chain)
            except Exception:                 # noqa: BLE001 -- the stroke at fault, in isolate()
                pass
    if made:            # (the candidates, κ's one reader, are made: segments read it no more)
        curves.drop_kappa()


def _command_for(seg, st, rules):
    """Put stroke st's junction command (corners.junction_commands) on its segment plan
    when corners.py slowed its start that way; False when none can be written (its plan,
    made from the slower start, must not be written either)."""
    if not st.corner_cmd0 or seg.first_cmds:
        return True
    cmds = junction_commands(st, rules.flavour, rules.junction)
    seg.first_cmds = cmds
    return cmds is not None


def _as_sliced(plan, pin, i, why):
    plan.retime[i] = False
    plan.reason[i] = why
    plan.segs[i] = None
    plan.t_pred[i], plan.a2_pred[i] = pin.T_orig[i], pin.I_orig[i]


def _attach_commands(plan, strokes, pin, rules, cmd0=None):
    """Every re-timed stroke whose start corners.py slowed by a junction command gets it
    (lines, curves and chains alike); one that cannot is left as sliced.  Only the
    strokes whose start corners.py slowed ask (_command_for: every other one has nothing
    to attach), found in one pass (none without --corners).  cmd0, if given: the
    strokes' corner_cmd0 as a bool array (plan_strokes reads them once for its runs)."""
    segs = plan.segs
    if cmd0 is not None:
        todo = np.flatnonzero(plan.retime & cmd0).tolist()
    else:
        todo = [i for i in np.flatnonzero(plan.retime).tolist() if strokes[i].corner_cmd0]
    for i in todo:
        seg = segs[i]
        if seg is not None and not _command_for(seg, strokes[i], rules):
            _as_sliced(plan, pin, i, "no junction command for its slower corner")


# why a stroke is left as sliced, for which its corner slowed by a command is still written
AS_SLICED = ("original is better within the time budget", "no law within limits",
             "segments would not beat the original")


def _keep_slowed_corners(plan, strokes, rules, cmd0=None):
    """A line stroke the planner leaves as sliced whose start corners.py slowed with a
    junction command keeps that corner: its own move is written behind the command
    (segments.slowed_original).  Its time counts in the budget like a re-timed stroke's;
    what the corner cost was priced in corners.py's share of the budget.  cmd0, if
    given: the strokes' corner_cmd0 as a bool array (only those rows are asked)."""
    for i in np.flatnonzero(~plan.retime if cmd0 is None else ~plan.retime & cmd0).tolist():
        st = strokes[i]
        if not st.corner_cmd0 or plan.reason[i] not in AS_SLICED or chains.plan_kind(st) != K_LINE:
            continue
        try:
            seg = slowed_original(st, rules)
        except Exception:                     # noqa: BLE001 -- the stroke stays as sliced
            seg = None
        if seg is None or seg_fault(seg) or not _command_for(seg, st, rules):
            continue
        plan.retime[i] = True
        plan.reason[i] = "retimed"
        plan.segs[i] = seg
        plan.T[i], plan.beta[i], plan.I_law[i] = seg.time_t, np.inf, seg.int_a2
        plan.t_pred[i], plan.a2_pred[i] = seg.time_t, seg.int_a2


def _lead_out_where_no_command(plan, strokes, pin, rules, seg_cache):
    """A stroke whose lowered end was to be set by the next stroke's junction command
    (corners.py: Stroke.corner_cmd1) gets its own lead-out when that next stroke is left
    as sliced or writes no command: otherwise the firmware would pass the corner at its
    own junction speed.  The change holds for the later plans of this run (their budget
    sees it); a stroke whose lead-out does not fit is left as sliced."""
    nxt = getattr(pin, "corner_next", None)
    if not nxt:
        return
    todo = True
    while todo:                  # a stroke left as sliced here may be another's next: again
        todo = False
        for a, b in nxt.items():
            if strokes[a].corner_cmd1 and plan.retime[a]:
                seg_b = plan.segs[b] if plan.retime[b] else None
                if seg_b is None or not getattr(seg_b, "first_cmds", None):
                    _own_lead_out(plan, strokes, pin, rules, seg_cache, a)
                    todo = True


def _own_lead_out(plan, strokes, pin, rules, seg_cache, a):
    """Stroke a's segments with its own lead-out at its lowered end, or a left as sliced."""
    st = strokes[a]
    st.corner_cmd1 = False
    seg_cache.alone(a)                        # (its class's plans are not its own any more)
    seg_cache.forget_line(a)
    try:
        seg = KINDS[K_LINE].segments([st], plan.T[[a]], plan.beta[[a]], rules, None)[0]
    except Exception:                         # noqa: BLE001 -- the stroke stays as sliced
        seg = None
    why = "segments would not beat the original" if seg is None else seg_fault(seg)
    if not why and not beats(seg.int_a2, st.int_a2):
        why = "segments would not beat the original"
    if not why and not _command_for(seg, st, rules):
        why = "no junction command for its slower corner"
    if why:
        _as_sliced(plan, pin, a, why)
        return
    plan.segs[a] = seg
    plan.t_pred[a], plan.a2_pred[a] = seg.time_t, seg.int_a2


REPLANS = 5              # law budgets tried after the first, at most
FULL_R = 0.05            # a plan spending within 5 % below the budget is taken


def _fit_budget(run, pin, budget_t):
    """The laws' budget whose segments' predicted time fills budget_t.  The segments cost
    more than their laws (lead-ins, firmware junctions), so the first plan may overspend:
    step the laws' budget down by the overspend (the set of strokes changes with it) and,
    once one plan is within the budget, bisect between the last over and the best within.
    A plain step-down overshot: on Marlin JD profiles, whose lead-ins cost most, three
    steps ended at 40 % of the budget spent and 366 strokes left as sliced.

    At most two plans live at once, the best within the budget and the one being made: a
    plan over the budget is dropped before the next is made (each holds a segment plan per
    re-timed stroke, and arcs' and curves' are new objects on every re-plan)."""
    tol = 1e-3 * budget_t + 1e-9

    def spent(p):
        return float(np.sum(p.t_pred - pin.T_orig, where=p.retime))

    plan = run(budget_t)
    s = spent(plan)
    if s <= budget_t + tol:
        return plan
    b, hi_b, best = budget_t, budget_t, None      # best: (law budget, plan, spent) within
    for _ in range(REPLANS):
        b = b - (s - budget_t) if best is None else 0.5 * (best[0] + hi_b)
        plan = None                               # over the budget, or held by best
        plan = run(b)
        s = spent(plan)
        if s > budget_t + tol:
            hi_b = b
            continue
        if best is None or s > best[2]:
            best = (b, plan, s)
        if s >= budget_t * (1.0 - FULL_R):
            break
    return plan if best is None else best[1]
