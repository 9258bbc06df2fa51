"""Plan: choose each stroke's duration T and weight beta under the machine's limits.

For a straight stroke the law (laws/line.py) is fixed by (L, T, beta, v0, v1).  The
limits are: peak speed <= v_cap (slicer F x (1 + overshoot), never above the machine's
max velocity nor the hotend's volumetric flow), peak |a| <= the acceleration in force,
speed >= 0 (no reversal), and a segment time the firmware can stream.

  --alpha A     beta = A * m2/m (per-axis masses along the stroke); T is the shortest
                duration meeting the limits.
  --alpha auto  at a given T, the inertia norm int a^2 dt falls as beta grows while the
                peak speed rises (beta -> inf is the min-int-a^2 cubic), so the best law
                at T is the largest beta whose peak speed is still <= v_cap.  Each stroke
                thus has a curve I(T); a global time budget (--max-slowdown x the file's
                print time) is spent where it buys most: minimise sum I_k + lambda sum T_k,
                lambda found by bisection.  Strokes whose best option is their original
                trapezoid are left untouched.
Everything is vectorised over strokes (numpy), so a file with 10^5 strokes plans in seconds.
"""
from __future__ import annotations

import os
from collections import namedtuple

import numpy as np

from .distinct import _row_hashes, classes_in_row_order
from .laws.line import InteriorSpeeds, cubic_figures, end_speeds, interior_speed, line_law, peak_root_guess

# candidate durations, as multiples of the stroke's original duration
T_RATIOS = np.array([0.70, 0.75, 0.80, 0.85, 0.90, 0.93, 0.96, 0.98, 1.0, 1.01, 1.02, 1.03,
                     1.04, 1.05, 1.07, 1.10, 1.13, 1.16, 1.20, 1.25, 1.30, 1.40, 1.50])
GAMMA_LO, GAMMA_HI = 1e-4, 1e6          # gamma = T/sqrt(beta): cubic ... constant speed
SPEED_TOL_R = 1e-6                      # relative slack when comparing with a cap
CANDIDATE_CHUNK = 2048                  # strokes per batch of line candidates (bounded memory)
_F64 = np.dtype(float)


class PlanInput:
    """Per-stroke arrays (all shape (n,)): FIELDS, in the constructor's order."""

    FIELDS = ("L", "v0", "v1", "v_cap", "a_cap", "T_orig", "I_orig", "mass_r", "t_seg_min")

    def __init__(self, L, v0, v1, v_cap, a_cap, T_orig, I_orig, mass_r, t_seg_min):
        self.L, self.v0, self.v1 = map(np.asarray, (L, v0, v1))
        self.v_cap, self.a_cap = np.asarray(v_cap), np.asarray(a_cap)
        self.T_orig, self.I_orig = np.asarray(T_orig), np.asarray(I_orig)
        self.mass_r = np.asarray(mass_r)          # m2_eff / m_eff (kg): beta = alpha * mass_r
        self.t_seg_min = np.asarray(t_seg_min)    # shortest duration a re-timed stroke may have


    # the inputs only the candidates read (their tables made once: plan_strokes' budget runs
    # read T_orig and I_orig), let go by set_aside until one is read again
    CANDIDATE_ONLY = ("L", "v0", "v1", "v_cap", "a_cap", "mass_r", "t_seg_min")

    def set_aside(self, folder=None) -> bool:
        """The CANDIDATE_ONLY arrays written to an unnamed temporary file in folder and let
        go (~2.9 MB through the rectilinear plate's budget runs, its planning peak): the
        first read of one of them reads them all back, the same bits.  False (all kept)
        where one is no plain contiguous array or the file cannot be made or written
        (plan.write_arrays, as Candidates.spill)."""
        if "_aside" in self.__dict__:           # (set aside already)
            return False
        arrays = [getattr(self, name) for name in self.CANDIDATE_ONLY]
        if not all(type(a) is np.ndarray for a in arrays):
            return False
        got = write_arrays(arrays, folder)
        if got is None:
            return False
        self._aside = got
        for name in self.CANDIDATE_ONLY:
            delattr(self, name)
        return True

    def __del__(self):
        """A file set aside and never read back (a job stopped by an error) closed here, not
        by the file object's finaliser, which warns (ResourceWarning) of a file it closes."""
        aside = self.__dict__.get("_aside")
        if aside is not None:
            aside[0].close()

    def __getattr__(self, name):
        """(Called for an attribute not found only.)  A CANDIDATE_ONLY array set aside: all
        of them read back from their file (set_aside), the file closed."""
        aside = self.__dict__.get("_aside")
        if aside is None or name not in self.CANDIDATE_ONLY:
            raise AttributeError(name)
        fh, layout = aside
        for field, a in zip(self.CANDIDATE_ONLY, read_arrays(fh, layout, "plan inputs set aside")):
            setattr(self, field, a)
        del self._aside
        fh.close()
        return getattr(self, name)

    def take(self, rows) -> "PlanInput":
        """The same arrays for the strokes `rows` only (fault isolation retries)."""
        rows = np.asarray(rows, int)
        return PlanInput(*(getattr(self, f).take(rows, axis=0) for f in self.FIELDS))


def _reasons(n, default, *cases):
    """A reason per stroke, as an object array: `default`, then each (mask, text) in turn,
    a later one where masks overlap.  (np.where on strings builds fixed-width unicode
    arrays, 4 bytes a character a stroke, twice: a transient of tens of MB on a plate.)"""
    out = np.empty(n, dtype=object)
    out[:] = default
    for mask, text in cases:
        out[np.asarray(mask, bool)] = text
    return out


def input_faults(p: PlanInput):
    """Reason per stroke ("" = fine) for plan inputs no law can be built on: non-finite
    or out-of-range lengths, speeds, caps, durations, norms or masses."""
    with np.errstate(invalid="ignore"):
        finite = np.ones(len(p.L), bool)
        for a in (p.L, p.v0, p.v1, p.v_cap, p.a_cap, p.T_orig, p.I_orig, p.mass_r, p.t_seg_min):
            finite &= np.isfinite(np.asarray(a, float))
        in_range = ((p.L > 0) & (p.v0 >= 0) & (p.v1 >= 0) & (p.v_cap > 0) & (p.a_cap > 0) & (p.T_orig > 0)
                    & (p.I_orig >= 0) & (p.mass_r > 0))
    return _reasons(len(finite), "", (~in_range, "error: plan input out of range"),
                    (~finite, "error: non-finite plan input"))


def isolate(fn, rows, stage, failed):
    """Run fn(sub_rows) on all `rows` at once (vectorised); on an exception, retry the
    two halves, down to single rows, so one failing stroke drops only itself.  numpy
    warnings are silenced (non-finite results are checked by the callers).  Records
    failed[row] = "error: <stage> (<exception>)"; returns [(sub_rows, fn's result)]."""
    rows = np.asarray(rows, int)
    pieces = []
    # a stack, not a recursive closure: a closure that calls itself is a reference cycle,
    # which held every piece (the candidate tables) until the next full garbage collection
    todo = [rows] if rows.size else []
    while todo:
        sub = todo.pop()
        try:
            with np.errstate(all="ignore"):
                pieces.append((sub, fn(sub)))
        except Exception as e:            # noqa: BLE001 -- any failure is this stroke's, not the file's
            if sub.size <= 1:
                for r in sub:
                    failed[int(r)] = f"error: {stage} ({type(e).__name__})"
                continue
            half = sub.size // 2
            todo += [sub[half:], sub[:half]]      # the first half next, as the recursion did
    return pieces


class SharedPiece(namedtuple("SharedPiece", "rows mask vals t_pos bad inv")):
    """The candidates of the strokes rows whose inputs repeat (pieces_once): row q has the
    entries of distinct row inv[q], whose mask, vals (row-major), t_pos and bad rows are
    those of a Candidates.piece of the distinct rows.  Candidates.of_pieces keeps the
    distinct rows' entries once.  Its fields are arrays.  (collections' namedtuple, not
    typing.NamedTuple: that one compiles each field's annotation, ~1 M instructions at
    every start.)"""
    __slots__ = ()


class Candidates:
    """The candidate tables (T, beta, I, KE), (n, k) by stroke and duration column, kept
    as their feasible entries only: those with a finite I, the only ones the allocation
    can choose (~17 % of the gyroid plate's, whose four dense tables held 24 MB to the end
    of the run).  mask (n, k): which; vals (4, m): their T, beta, I, KE; a row's entries
    are vals[:, first:first + cnt] (first, cnt (n,): intp), in its columns' order; t_pos
    (n,): every duration of the row's dense T >= 0 (what plan.allocate's test for costs
    that cannot cancel read of the others).  Rows made together from one set of inputs
    (SharedPiece: lines that repeat) share their entries: the rectilinear plate's 48.6 k
    lines hold those of their 6.2 k distinct inputs (~1.5 MB, not ~12 MB); the others'
    are in row-major order, as the dense tables hold them.  The mask is held as each
    entry's column (col, int8), a row's entries in its columns' order: the (n, k) bools
    were 1.2 MB on the rectilinear plate through the budget runs, the rewrite and the
    measure (a second pass re-plans with them), where the allocation reads only cnt.
    Iterating gives the dense tables (T: the infeasible entries are T_orig x T_RATIOS)."""
    __slots__ = ("col", "k", "vals", "first", "cnt", "t_pos", "T_orig")

    def __init__(self, mask, vals, t_pos, T_orig, first=None, cnt=None):
        """first, cnt: each row's entries in vals; None: mask's True entries in row-major
        order (cnt, when given, is mask.sum(axis=1))."""
        self.vals, self.t_pos, self.T_orig = vals, t_pos, T_orig
        self.cnt = np.ascontiguousarray(mask.sum(axis=1) if cnt is None else cnt, np.intp)
        self.first = np.ascontiguousarray(np.cumsum(self.cnt) - self.cnt if first is None else first, np.intp)
        self.k = mask.shape[1]
        self.col = _entry_columns(mask, self.first, self.cnt, vals.shape[1])

    @property
    def shape(self):
        return self.cnt.size, self.k

    # the arrays spill() writes out: every one of its own (T_orig is planning's input, held anyway)
    SPILLED = ("col", "vals", "first", "cnt", "t_pos")

    def spill(self, folder=None):
        """These tables written to an unnamed temporary file in folder (SpilledCandidates),
        their memory let go until load() reads them back, the same bits and layout; None
        (and nothing written) where the file cannot be made or written.  Weights set aside
        (set_aside_weights) stay in their own file, handed to the SpilledCandidates."""
        aside = self.vals if type(self.vals) is _AsideVals else None
        got = write_arrays([aside.ti if aside is not None and name == "vals" else getattr(self, name)
                            for name in self.SPILLED], folder)
        return None if got is None else SpilledCandidates(*got, self.k, self.T_orig,
                                                          None if aside is None else aside.weights)

    def set_aside_weights(self, folder=None) -> bool:
        """The entries' beta and KE (vals[1], vals[3]) written to an unnamed temporary file in
        folder and let go: the allocation reads only T and I (vals[0], vals[2]); beta and KE
        are read at the chosen entries once a budget run (_chosen_figures), a few chunks of
        the file (_AsideVals; windowed gyroid plate: 1.7 MB held from the candidates through
        the runs, the command's peak).  vals indexes as before, the same bits.  False (all
        kept) where vals is no C-contiguous (4, m) array of doubles or the file cannot be
        made or written."""
        vals = self.vals
        if type(vals) is not np.ndarray or vals.dtype != _F64 or vals.ndim != 2 or vals.shape[0] != 4 \
                or not vals.flags.c_contiguous:
            return False
        # T and I written too and read back once vals is let go: a copy of them made beside
        # vals raised the windowed gyroid's candidates moment by its 1.7 MB
        weights = _WeightsFile.of((vals[1], vals[3], vals[0], vals[2]), folder)
        if weights is None:
            return False
        self.vals = vals = None
        self.vals = _AsideVals(weights.rows(2, 4), weights)
        return True

    @property
    def mask(self):
        """(n, k) bool: which candidates are feasible (made from col)."""
        return self._mask_rows(np.arange(self.cnt.size))

    def _mask_rows(self, rows):
        """mask[rows] (rows: an int array), made from their entries' columns."""
        cnt = self.cnt[rows]
        out = np.zeros((rows.size, self.k), bool)
        total = int(cnt.sum())
        if total:
            at = np.repeat(self.first[rows] - (np.cumsum(cnt) - cnt), cnt) + np.arange(total)
            out[np.repeat(np.arange(rows.size), cnt), self.col[at]] = True
        return out

    @classmethod
    def of_tables(cls, T, beta, I, KE, T_orig=None):
        """From dense tables as candidates_auto gives them."""
        T, beta, I, KE = (np.asarray(x, float) for x in (T, beta, I, KE))
        mask = np.isfinite(I)
        return cls(mask, np.stack([T[mask], beta[mask], I[mask], KE[mask]]), (T >= 0.0).all(axis=1), T_orig)

    @staticmethod
    def piece(sub, tables, T_orig):
        """One isolate() piece (rows sub, its (T, beta, I, KE)) kept sparse: (sub, mask,
        vals, t_pos, bad rows).  A candidate with a non-finite T, beta = nan, or a finite
        I with a non-finite KE is infeasible, and its whole row (the caller counts that
        stroke as failed: nothing non-finite is chosen)."""
        t, b, i, ke = (np.asarray(x, float) for x in tables)
        with np.errstate(invalid="ignore"):
            t_finite = np.isfinite(t)
            bad = ~t_finite | np.isnan(b) | np.isnan(i) | (np.isfinite(i) & ~np.isfinite(ke))
            bad_row = bad.any(axis=1)             # the caller drops the whole row (failed)
            mask = np.isfinite(i) & ~bad & ~bad_row[:, None]
            del bad
            if t_finite.all():                    # (every T finite: the fill below is never taken)
                t_pos = (t >= 0.0).all(axis=1)
            else:
                t_fill = T_orig[sub, None] * T_RATIOS[None, :]
                t_pos = (np.where(t_finite, t, t_fill) >= 0.0).all(axis=1)
        # the feasible entries straight into their rows (mask's True entries in row-major
        # order, as t[mask]), not four copies stacked (~24 MB at once on the rectilinear
        # plate's lines, beside the dense tables): their places found once, not by each
        # table's np.compress, and taken into the rows in place (mode "clip": the places
        # are in range; "raise" with out= fills a temporary and copies it)
        at = np.flatnonzero(mask)
        vals = np.empty((4, at.size))
        for row, x in zip(vals, (t, b, i, ke)):
            np.take(np.ascontiguousarray(x).ravel(), at, out=row, mode="clip")
        return sub, mask, vals, t_pos, bad_row

    @classmethod
    def of_pieces(cls, n, pieces, T_orig):
        """The tables of n strokes from Candidates.piece()s and SharedPieces of disjoint
        rows; rows no piece covers are infeasible.  Returns (Candidates, rows holding a non-finite candidate,
        sorted).  tests/test_memory_plan.py compares them with the dense tables.

        The list pieces is emptied: each piece's values are let go once copied, so the
        pieces and the table they make are not all held at once while it is filled (the
        pieces' values are ~12 MB on the rectilinear plate; that moment was not the plan's
        peak, so the peak did not move).  The entries' columns are taken from each piece's
        mask as it is copied, not from an (n, k) mask of every row made first (1.2 MB on
        the rectilinear plate, with _entry_columns' temporaries the windowed candidates'
        peak there: benchmarks/cand52.md)."""
        k = len(T_RATIOS)
        cnt = np.zeros(n, np.intp)
        t_pos = _ratios_nonneg(T_orig)
        own = np.ones(n, bool)                # rows whose entries are their own (not shared)
        bad = []
        for pc in pieces:
            if type(pc) is SharedPiece:
                cnt[pc.rows], t_pos[pc.rows] = pc.mask.sum(axis=1)[pc.inv], pc.t_pos[pc.inv]
                own[pc.rows] = False
                bad.append(pc.rows[pc.bad[pc.inv]])
            else:
                sub, m, _, tp, b = pc
                cnt[sub], t_pos[sub] = m.sum(axis=1), tp
                bad.append(sub[b])
        # the own rows' entries first, in row-major order (all of them, without shared
        # pieces: the layout of the dense tables' mask), then each shared piece's distinct ones
        own_cnt = np.where(own, cnt, 0)
        first = np.cumsum(own_cnt) - own_cnt
        end = int(own_cnt.sum())
        del own, own_cnt
        at = []
        for pc in pieces:
            if type(pc) is SharedPiece:
                cnt_u = pc.mask.sum(axis=1)
                first[pc.rows] = end + (np.cumsum(cnt_u) - cnt_u)[pc.inv]
                at.append(end)
                end += int(cnt_u.sum())
        if end >= TRIM_ENTRIES:
            # the heap's free pages given back before the table is made: the candidates freed
            # ~7 MB of transients in the middle of the heap, resident, and the table and the
            # pieces' copies grew the windowed gyroid plate's peak on top of them (mem59.md)
            from .pipeline import trim_heap
            trim_heap()
        out = cls._of_layout(k, np.empty((4, end)), t_pos, T_orig, first, cnt)
        while pieces:
            pc = pieces.pop()
            if type(pc) is SharedPiece:
                # (every distinct row is some row's: pieces_once's and PiecesMemo's are made
                # of their rows' first ones)
                a = at.pop()
                out.vals[:, a:a + pc.vals.shape[1]] = pc.vals
                out.col[a:a + pc.vals.shape[1]] = np.flatnonzero(pc.mask) % k
            else:
                # a figure's row at a time: 1-D scatters (~20 instructions an entry; the
                # (4, k) scatter through a slice and an index array, ~42)
                at_pos = out._positions(pc[0], pc[1])
                for dst, src in zip(out.vals, pc[2]):
                    dst[at_pos] = src
                out.col[at_pos] = np.flatnonzero(pc[1]) % k
            del pc
        return out, (np.sort(np.concatenate(bad)) if bad else np.zeros(0, int))

    @classmethod
    def _of_layout(cls, k, vals, t_pos, T_orig, first, cnt):
        """Tables of k columns whose entries are vals, each row's first[r] .. first[r] +
        cnt[r] (intp); their columns (col) all 0, for the caller to fill."""
        out = cls.__new__(cls)
        out.vals, out.t_pos, out.T_orig, out.first, out.cnt, out.k = vals, t_pos, T_orig, first, cnt, k
        out.col = np.zeros(vals.shape[1], np.int8 if k <= 127 else np.intp)
        return out

    def __iter__(self):
        n, k = self.shape
        mask = self.mask
        T = np.zeros((n, k)) if self.T_orig is None else self.T_orig[:, None] * T_RATIOS[None, :]
        beta, I, KE = np.full((n, k), np.inf), np.full((n, k), np.inf), np.full((n, k), np.nan)
        entries = self.vals[:, self._positions(np.arange(n), mask)]     # (row-major, as mask's)
        for a, v in zip((T, beta, I, KE), entries):
            a[mask] = v
        return iter((T, beta, I, KE))

    def allocation_tables(self, rows, T_orig, I_orig):
        """allocate's (Tx, Ix, finite, settle) for the strokes rows: durations and costs with
        the original as the last column; an infeasible entry's T is 0 (never read)."""
        n, k = rows.size, self.k
        m = np.zeros((n, k + 1), bool)
        m[:, :k] = self._mask_rows(rows)
        pos = self._positions(rows, m[:, :k])
        Tx = np.zeros((n, k + 1))
        Ix = np.full((n, k + 1), np.inf)
        Tx[m] = self.vals[0, pos]          # row-major, as m's True entries
        Ix[m] = self.vals[2, pos]
        del m, pos                         # before the checks below: ~2 MB on the gyroid plate
        Tx[:, k], Ix[:, k] = T_orig, I_orig
        finite = np.isfinite(Ix)
        settle = bool(np.all(Ix[finite] >= 0.0) and np.all(self.t_pos[rows]) and np.all(Tx[:, k] >= 0.0))
        return Tx, Ix, finite, settle

    def rows_view(self, rows, T_orig, I_orig):
        """What the compiled allocation (_allocate_rows) reads of the strokes rows, the
        candidates left where they are: _RowsView (each row's first entry in vals and its
        count, the rows' originals, settle).  A row's candidates then its original are the
        costs, in the dense order, that the dense (n, k + 1) tables hold finite (~5 of 24 a
        line); the packed copies of them this replaced were ~10 MB on the rectilinear plate.
        None where the choices could differ from the dense ones: a cost that could overflow
        or a T that is not finite and >= 0 (then a least cost may be inf, and which inf
        argmin takes depends on the columns), an original not finite."""
        T_orig = np.ascontiguousarray(T_orig, float)
        I_orig = np.ascontiguousarray(I_orig, float)
        if not (np.isfinite(T_orig).all() and np.isfinite(I_orig).all()):
            return None
        first, cnt = _rows_of(self.first, rows), _rows_of(self.cnt, rows)
        # the entries of the rows: all of vals when the rows hold every row with one (the
        # usual case: only failed strokes are left out), else those rows' entries (the
        # checks below are of every entry: an entry two rows share is checked once)
        into = np.zeros(self.cnt.size, bool)
        into[rows] = True
        if not self.cnt[~into].any():
            T, I = self.vals[0], self.vals[2]
        else:
            used = self._entries_of(first, cnt)
            T, I = self.vals[0, used], self.vals[2, used]
            del used
        del into
        settle = bool(np.all(self.t_pos[rows]))
        for t_all, i_all in ((T, I), (T_orig, I_orig)):
            for a in range(0, t_all.size, CHECK_ENTRIES):       # (bounded temporaries)
                t, i = t_all[a:a + CHECK_ENTRIES], i_all[a:a + CHECK_ENTRIES]
                fin = np.isfinite(i)
                with np.errstate(over="ignore", invalid="ignore"):
                    if not (np.isfinite(t).all() and t.min(initial=0.0) >= 0.0 and np.all(np.abs(i[fin]) < 1e300)
                            and np.all(t * LAMBDA_MAX < 1e300)):
                        return None
                settle = settle and bool(np.all(i[fin] >= 0.0))
        return _RowsView(first, cnt, T_orig, I_orig, settle)

    def _positions(self, rows, mask_rows):
        """Indices into vals of the True entries of mask_rows (= mask[rows]), row-major."""
        cnt = mask_rows.sum(axis=1)
        run = np.cumsum(cnt) - cnt
        return np.repeat(self.first[rows] - run, cnt) + np.arange(int(cnt.sum()))

    def _entries_of(self, first, cnt):
        """Which entries of vals (a bool per entry) are in the rows' spans [first, first +
        cnt): their starts less their ends, summed along vals."""
        m = self.vals.shape[1]
        edges = np.bincount(first, minlength=m + 1) - np.bincount(first + cnt, minlength=m + 1)
        return np.cumsum(edges[:m]) > 0

    def at(self, rows, cols):
        """(T, beta, I, KE) of the feasible entries (rows[q], cols[q])."""
        before = np.cumsum(self._mask_rows(rows), axis=1, dtype=np.int32)[np.arange(rows.size), cols] - 1
        return self.vals[:, self.first[rows] + before]


def _rows_of(a, rows):
    """a[rows] (rows: a 1-D int array), or a itself where rows are all of its rows in
    order (0 .. n - 1: the usual group, every stroke but failed ones): the same values,
    read only, without a copy (a budget run's _RowsView held copies of first, cnt, T_orig
    and I_orig: ~1.6 MB through the rectilinear plate's runs)."""
    n = a.shape[0]
    if (rows.ndim == 1 and rows.dtype.kind in "iu" and rows.size == n and (n == 0 or (rows[0] == 0 and rows[-1] == n - 1))
            and (n < 2 or bool((rows[1:] > rows[:-1]).all()))):
        return a            # (n strictly increasing ints from 0 to n - 1: 0 .. n - 1)
    return a[rows]


ENTRY_ROWS = 8192      # _entry_columns: rows whose mask entries are placed at once
TRIM_ENTRIES = 1 << 16  # Candidates.of_pieces: tables of as many entries made on a trimmed heap


RATIO_ROWS_MIN = 512     # _ratios_nonneg: fewer rows are reduced as they are (natively 1.7x at 200 rows)


def _ratios_keep_sign(ratios):
    """Whether the ratios are all positive and finite, one of them 1.0."""
    return bool(np.all((ratios > 0.0) & (ratios < np.inf))) and bool(np.any(ratios == 1.0))


def _ratios_nonneg(T_orig):
    """((T_orig[:, None] * T_RATIOS[None, :]) >= 0.0).all(axis=1), the same booleans: the
    products ratio by ratio into the rows of a (k, n) table, then all down its columns
    (numpy reduces an (n, k) table's short rows through its buffers: ~20 instructions an
    entry, ~2.5 so; below RATIO_ROWS_MIN rows the k products' calls cost more)."""
    if T_orig.ndim == 1 and T_orig.dtype == np.float64 and _ratios_keep_sign(T_RATIOS):
        # x * r >= 0.0 for every ratio r iff x >= 0.0: r = 1.0 gives x itself, and a product
        # of a positive finite r keeps x's sign (+-0.0, an underflow, an inf) or its NaN
        return T_orig >= 0.0
    if T_orig.ndim != 1 or T_orig.dtype != np.float64 or T_orig.size < RATIO_ROWS_MIN:
        return ((T_orig[:, None] * T_RATIOS[None, :]) >= 0.0).all(axis=1)
    P = np.empty((T_RATIOS.size, T_orig.size))
    for c in range(T_RATIOS.size):
        np.multiply(T_orig, T_RATIOS[c], out=P[c])
    return np.greater_equal(P, 0.0).all(axis=0)


class SpilledCandidates:
    """A Candidates' tables in an unnamed temporary file (Candidates.spill): the first pass
    holds them only in case the time budget re-plans (a second rewrite pass: 9 of the 54
    reference cases, neither plate), and its measure was the rectilinear plate's peak with
    them held.  load() gives them back once, bit for bit; the file goes with it.  weights:
    the _WeightsFile of tables whose weights were set aside (their vals' T and I rows are
    this file's), given back with them."""
    __slots__ = ("fh", "layout", "k", "T_orig", "weights")

    def __init__(self, fh, layout, k, T_orig, weights=None):
        self.fh, self.layout, self.k, self.T_orig, self.weights = fh, layout, k, T_orig, weights

    def load(self):
        out = Candidates.__new__(Candidates)
        out.k, out.T_orig = self.k, self.T_orig
        for name, a in zip(Candidates.SPILLED, read_arrays(self.fh, self.layout, "spilled candidate tables")):
            setattr(out, name, a)
        if self.weights is not None:
            out.vals, self.weights = _AsideVals(out.vals, self.weights), None
        self.close()
        return out

    def close(self):
        """The file let go unread (no re-plan came): closed here, not left to the collector
        (which closes it too, with a ResourceWarning)."""
        if self.fh is not None:
            self.fh.close()
            self.fh = None
        if self.weights is not None:
            self.weights.close()
            self.weights = None


class _WeightsFile:
    """Rows of doubles (the entries' beta and KE, then T and I: Candidates.set_aside_weights)
    in an unnamed temporary file, read back at given entries a chunk of the file at a time
    (take), so that no row is held whole again.  Closed by close() or when collected (not by the file
    object's finaliser, which warns of a file it closes)."""
    __slots__ = ("fh", "m")

    CHUNK_BITS = 13     # take reads chunks of 2 ** CHUNK_BITS entries at most (64 kB: its only buffer)

    def __init__(self, fh, m):
        self.fh, self.m = fh, m

    @classmethod
    def of(cls, rows, folder=None):
        """The rows (contiguous 1-D arrays of m doubles each, written one after the other:
        no copy of them made) in a file in folder, or None where it cannot be made or
        written."""
        got = write_arrays(list(rows), folder)
        return None if got is None else cls(got[0], rows[0].size)

    def take(self, rows, idx):
        """The entries at idx (an int array, or anything np.arange(m)[idx] takes) of each of
        rows (row numbers), as a new (len(rows),) + idx's shape array: the places grouped by
        chunk of 2 ** CHUNK_BITS entries once for all the rows (a radix sort of their chunks' 16-bit
        numbers: a sort of the places themselves, a row at a time, was ~40 M instructions
        on the rectilinear plate), each chunk's read from its first place asked to its last."""
        m = self.m
        pos = np.arange(m)[idx] if not isinstance(idx, np.ndarray) or idx.dtype.kind not in "iu" else idx
        flat = np.asarray(pos, np.intp).ravel()
        out = np.empty((len(rows), flat.size))
        if flat.size:
            if flat.min() < 0:
                flat = np.where(flat < 0, flat + m, flat)
            if not (0 <= int(flat.min()) and int(flat.max()) < m):
                raise IndexError("_WeightsFile: an entry out of range")
            chunk = flat >> self.CHUNK_BITS
            if m >> self.CHUNK_BITS < 1 << 15:
                chunk = chunk.astype(np.int16)       # (numpy sorts 16-bit ints stably by radix)
            order = np.argsort(chunk, kind="stable")
            at = flat[order]
            ends = (np.flatnonzero(np.diff(chunk[order])) + 1).tolist() + [at.size]
            fd, size = self.fh.fileno(), _F64.itemsize
            i = 0
            for j in ends:
                part = at[i:j]
                lo = int(part[0]) if j - i == 1 else int(part.min())
                rel = part - lo
                n = int(rel.max()) + 1
                dst = order[i:j]
                for q, r in enumerate(rows):
                    out[q, dst] = _read_doubles(fd, (r * m + lo) * size, n)[rel]
                i = j
        return out.reshape((len(rows),) + np.shape(pos))

    def rows(self, a, b):
        """Rows a..b-1 as a new (b - a, m) array."""
        m = self.m
        return _read_doubles(self.fh.fileno(), a * m * _F64.itemsize, (b - a) * m).reshape(b - a, m)

    def close(self):
        if getattr(self, "fh", None) is not None:
            self.fh.close()
            self.fh = None

    def __del__(self):
        self.close()


def _read_doubles(fd, at_b, n):
    """n doubles of the file fd from byte at_b; OSError if the file is cut short."""
    out = np.empty(n)
    mv, got = memoryview(out).cast("B"), 0
    while got < out.nbytes:
        k = os.preadv(fd, [mv[got:]], at_b + got)
        if k <= 0:
            raise OSError("the candidate tables' weights set aside were cut short")
        got += k
    return out


class _AsideVals:
    """Candidates.vals of tables whose weights were set aside (set_aside_weights), indexed as
    the (4, m) array was where plan.py reads it: vals[0] and vals[2] (T, I: ti, held), vals[1]
    and vals[3] (beta, KE) rows whose [idx] reads the file (_WeightsFile.take), vals[f, idx],
    vals[:, idx] (a (4, len) array), shape; np.asarray(vals) reads it all back."""
    __slots__ = ("ti", "weights")

    def __init__(self, ti, weights):
        self.ti, self.weights = ti, weights

    @property
    def shape(self):
        return 4, self.ti.shape[1]

    def __len__(self):
        return 4

    def _row(self, f):
        f = range(4)[f]                 # (negative rows as numpy's; IndexError beyond)
        return self.ti[f // 2] if f % 2 == 0 else _AsideRow(self.weights, f // 2)

    def __getitem__(self, key):
        if type(key) is not tuple:
            return self._row(key)
        f, idx = key
        if f == slice(None):
            w = self.weights.take((0, 1), idx)        # (both weights' rows read together)
            return np.stack([self.ti[0][idx], w[0], self.ti[1][idx], w[1]])
        return self._row(f)[idx]

    def __iter__(self):
        return map(self._row, range(4))

    def __array__(self, dtype=None, copy=None):
        w = self.weights.rows(0, 2)
        out = np.stack([self.ti[0], w[0], self.ti[1], w[1]])
        return out if dtype is None else out.astype(dtype)


class _AsideRow:
    """Row r of a _WeightsFile: [idx] reads its entries at idx."""
    __slots__ = ("weights", "r")

    def __init__(self, weights, r):
        self.weights, self.r = weights, r

    def __getitem__(self, idx):
        return self.weights.take((self.r,), idx)[0]


def write_arrays(arrays, folder=None):
    """(fh, layout): arrays written to an unnamed temporary file in folder, for read_arrays
    to give back, the same bits and memory order; None (nothing kept) where one is neither
    C- nor Fortran-contiguous, or the file cannot be made or written."""
    from .outfile import unnamed_file
    try:            # (unbuffered: the arrays' bytes go to the file without a copy)
        fh = unnamed_file(folder)
    except OSError:
        return None
    try:
        layout = []
        for a in arrays:
            # (a Fortran-ordered array as its transpose's C bytes: the layout a reduction's
            # order, and so its bits, may depend on comes back as it was)
            order = "C" if a.flags.c_contiguous else "F" if a.flags.f_contiguous else None
            if order is None:
                fh.close()
                return None
            buf, done = (a if order == "C" else a.T).data.cast("B") if a.nbytes else b"", 0
            while done < len(buf):
                done += fh.write(buf[done:])
            layout.append((a.dtype, a.shape, order))
    except OSError:
        fh.close()
        return None
    return fh, layout


def read_arrays(fh, layout, what):
    """The arrays write_arrays wrote to fh (layout: its own), read from the file's start;
    OSError naming `what` if the file is cut short.  fh is left open."""
    fh.seek(0)
    out = []
    for dtype, shape, order in layout:
        a = np.empty(shape if order == "C" else shape[::-1], dtype)
        buf, got = a.data.cast("B") if a.nbytes else None, 0
        while got < a.nbytes:
            k = fh.readinto(buf[got:])
            if not k:
                raise OSError(f"the {what} were cut short")
            got += k
        out.append(a if order == "C" else a.T)
    return out


def _entry_columns(mask, first, cnt, m):
    """Each of the m entries' column (int8 where the columns fit): row r's True columns
    of mask, in order, are those of its entries first[r] .. first[r] + cnt[r] (rows that
    share entries have the same mask rows: each writes the same columns)."""
    k = mask.shape[1]
    col = np.zeros(m, np.int8 if k <= 127 else np.intp)
    for a in range(0, mask.shape[0], ENTRY_ROWS):        # (bounded temporaries: ~5 entries a row)
        # row-major, each row's columns ascending: the True entries' flat places in the
        # block, modulo its width (np.nonzero of the 2-D block, which also made their rows,
        # was ~40 M instructions on the rectilinear plate)
        cc = np.flatnonzero(mask[a:a + ENTRY_ROWS]) % k
        c = cnt[a:a + ENTRY_ROWS]
        col[np.repeat(first[a:a + ENTRY_ROWS] - (np.cumsum(c) - c), c) + np.arange(cc.size)] = cc
    return col


class Plan:
    """Chosen law per stroke: retime mask, T, beta and the law's own figures.  remake: what
    makes the segment plans a windowed run let go (schedule.segs_for), or None: plan.segs
    holds every re-timed row's plan."""

    remake = None

    def __init__(self, n):
        self.retime = np.zeros(n, bool)
        self.T = np.zeros(n)
        self.beta = np.full(n, np.inf)
        self.I_law = np.zeros(n)          # int a^2 dt of the chosen law
        self.KE_law = np.zeros(n)         # int v^2 dt
        # (every entry the one "", as a list of them made it; np.full's "" is a unicode
        # scalar made into a str object entry by entry: ~85 instructions an entry, not ~35)
        self.reason = _reasons(n, "")
        self.lam = 0.0

    def put(self, rows, other: "Plan"):
        """Rows `rows` of this plan from `other` (a plan of len(rows) strokes)."""
        for k in ("retime", "T", "beta", "I_law", "KE_law", "reason"):
            getattr(self, k)[rows] = getattr(other, k)

    def copy(self) -> "Plan":
        p = Plan(0)
        for k in ("retime", "T", "beta", "I_law", "KE_law", "reason"):
            setattr(p, k, getattr(self, k).copy())
        p.lam = self.lam
        p.remake = self.remake
        return p


def _feasible(law, v_cap, a_cap):
    return ((law.peak_speed() <= v_cap * (1 + SPEED_TOL_R)) & (law.peak_accel() <= a_cap * (1 + SPEED_TOL_R))
            & (law.min_speed() >= -1e-9 * (1 + v_cap)))


def _largest_beta_under_speed_cap(L, T, v0, v1, v_cap, iters=32):
    """gamma_v: the smallest gamma (largest beta) whose peak speed <= v_cap.  Peak speed
    falls monotonically as gamma grows (the law flattens towards constant speed).

    On laws whose inputs are plain (_plain_laws) the root search of _largest_beta_plain,
    elementwise (broadcast, then flat).  On others (a duration not finite and > 0, a
    length or end speed not finite, a beta to try underflowing to 0), as before: bisection
    on log gamma, `iters` steps, each evaluating only the law's interior extremum
    (line.interior_speed, one gamma branch per law; the end speeds do not depend on beta
    and are computed once), which raises where the law does."""
    L, T, v0, v1, v_cap = np.broadcast_arrays(*(np.asarray(a, float) for a in (L, T, v0, v1, v_cap)))
    if _plain_laws(L, T, v0, v1):
        return _largest_beta_plain(*(a.ravel() for a in (L, T, v0, v1, v_cap)))[0].reshape(L.shape)
    lo = np.full(L.shape, np.log(GAMMA_LO))
    hi = np.full_like(lo, np.log(GAMMA_HI))
    cap = v_cap * (1 + SPEED_TOL_R)
    v_end = np.maximum(*end_speeds(L, T, v0, v1))
    cubic_ok = np.maximum(v_end, interior_speed(L, T, np.inf, v0, v1)) <= cap
    # a law whose cubic (beta = inf) is under the cap takes beta = inf whatever the
    # bisection finds: it is left out of it (unless a beta it would try underflows to 0,
    # which makes interior_speed raise: then it stays in, so the same rows raise)
    with np.errstate(all="ignore"):
        skip = cubic_ok & ((T / (2.0 * GAMMA_HI)) ** 2 > 0.0)
    if skip.any():
        gamma = np.full(L.shape, np.inf)
        b = ~skip
        if b.any():
            gamma[b] = np.exp(_bisect_log_gamma(L[b], T[b], v0[b], v1[b], cap[b], v_end[b], lo[b], hi[b], iters))
    else:
        gamma = np.exp(_bisect_log_gamma(L, T, v0, v1, cap, v_end, lo, hi, iters))
    return np.where(cubic_ok, np.inf, (T / gamma) ** 2)


def _plain_laws(L, T, v0, v1):
    """Whether no law (L, T, v0, v1) can make the search raise: T finite > 0, L, v0, v1
    finite, and (T / (2 GAMMA_HI))^2 > 0 (no beta it tries underflows to 0)."""
    with np.errstate(all="ignore"):
        return bool(np.isfinite(T).all() and (T > 0).all() and np.isfinite(L).all() and np.isfinite(v0).all()
                    and np.isfinite(v1).all() and ((T / (2.0 * GAMMA_HI)) ** 2 > 0.0).all())


def _bisect_log_gamma(L, T, v0, v1, cap, v_end, lo, hi, iters):
    """The upper end of the bisection bracket on log gamma (each row's own steps)."""
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        g = np.exp(mid)
        ok = np.maximum(v_end, interior_speed(L, T, (T / g) ** 2, v0, v1)) <= cap
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    return hi


def candidates_auto(p: PlanInput, chunk=CANDIDATE_CHUNK):
    """For each stroke and each candidate T: the best beta and its int a^2 (inf if no
    law with that T meets the limits).  Returns (T, beta, I, KE) of shape (n, k).

    Computed `chunk` strokes at a time: every step is per candidate, so the tables are
    the same as in one piece, and the temporaries stay a few MB whatever the file.  The
    root searches on beta (_beta_search) are made BISECT_CHUNKS chunks at a time (each entry
    its own steps, elementwise: the same bits) in numpy calls that many times larger than
    a chunk's (~1.7 k entries a chunk on the rectilinear plate, where the calls' overhead
    was half the bisection's time).  Between the two passes a chunk keeps its live
    entries' positions and interior speeds (12 bytes an entry, ~0.3 MB a chunk there; all
    chunks at once held 8 MB, and the plan's peak RSS grew by ~5 MB)."""
    n = len(p.L)
    if n <= chunk:
        return _candidates_auto(p)
    out = [np.empty((n, len(T_RATIOS))) for _ in range(4)]
    for a, b, tables in _chunk_tables(p, chunk):
        for o, piece in zip(out, tables):
            o[a:b] = piece
    return tuple(out)


def candidate_pieces(p: PlanInput, rows, T_orig, chunk=CANDIDATE_CHUNK):
    """candidates_auto(p)'s tables of the strokes rows (p: their PlanInput) kept sparse a
    chunk at a time: [Candidates.piece of each chunk's rows].  The same entries as
    Candidates.piece(rows, candidates_auto(p), T_orig) (each row's own), without the
    dense (n, 23) tables of all the rows at once (four of them, ~12 MB for 16 k lines)."""
    rows = np.asarray(rows)
    if len(p.L) <= chunk:
        return [Candidates.piece(rows, _candidates_auto(p), T_orig)]
    out = []
    for a, b, tables in _chunk_tables(p, chunk):
        out.append(Candidates.piece(rows[a:b], tables, T_orig))
        del tables          # (a comprehension's name held them while the next chunk's were made)
    return out


def pieces_once(make, p: PlanInput, rows, T_orig):
    """make(p, rows, T_orig) (candidate_pieces: [Candidates.piece]) with each distinct set
    of inputs made once (_same_inputs): strokes with the same inputs, bit for bit, have the
    same entries (each entry is its row's own), so the first of each is made and the
    others share its entries: [SharedPiece].  Where no set repeats enough, or make's pieces
    are not the first rows' in order, make of every row."""
    return _pieces_once(make, lambda sel=None: p if sel is None else p.take(sel), rows, T_orig)


def pieces_once_of(make, pin: PlanInput, rows):
    """pieces_once(make, pin.take(rows), rows, pin.T_orig), the same pieces, without that
    copy of the rows' inputs held while the distinct ones' pieces are made (~3.8 MB of
    the rectilinear plate's lines, at the candidates' peak): taken from pin again where
    needed."""
    rows = np.asarray(rows)
    return _pieces_once(make, lambda sel=None: pin.take(rows if sel is None else rows[sel]), rows, pin.T_orig)


def _pieces_once(make, inputs, rows, T_orig):
    """pieces_once of the PlanInput inputs() (inputs(sel): that of rows[sel] only, the
    same numbers), each made when it is read."""
    rows = np.asarray(rows)
    p = inputs()
    same = _same_inputs(p)
    if same is None:
        return make(p, rows, T_orig)
    del p
    first, inv = same
    made = make(inputs(first), rows[first], T_orig)
    if not _made_in_order(made, rows[first]):
        return make(inputs(), rows, T_orig)
    return [_shared_piece(rows, made, inv)]


def _made_in_order(made, rows):
    """Whether make's pieces (Candidates.piece) are of the rows, in order."""
    return np.array_equal(np.concatenate([pc[0] for pc in made]) if made else rows[:0], rows)


def _shared_piece(rows, made, inv):
    """The SharedPiece of rows whose distinct inputs' pieces (in order) are made.  The
    list made is emptied: each piece let go once copied into the joined arrays (the
    pieces and their join were both held: ~1 MB on the rectilinear plate's lines)."""
    shapes = [(pc[1].shape[0], pc[2].shape[1]) for pc in made]
    n_rows, n_vals = (sum(s[j] for s in shapes) for j in range(2))
    pc = made[0]
    out = SharedPiece(rows, np.empty((n_rows, pc[1].shape[1]), pc[1].dtype), np.empty((4, n_vals), pc[2].dtype),
                      np.empty(n_rows, pc[3].dtype), np.empty(n_rows, pc[4].dtype), inv)
    a = b = 0
    made.reverse()
    while made:
        pc = made.pop()
        r, v = pc[1].shape[0], pc[2].shape[1]
        out.mask[a:a + r], out.t_pos[a:a + r], out.bad[a:a + r] = pc[1], pc[3], pc[4]
        out.vals[:, b:b + v] = pc[2]
        a, b = a + r, b + v
        del pc
    return out


# the distinct inputs a PiecesMemo holds before it makes their pieces, in one call: a call
# pays the bisection's set-up (_log_gamma_root's steps, whatever its rows: ~6 M instructions),
# and the windowed rectilinear plate's 11 line units met 3.4 k new inputs in the first, then
# 1.3 k, 116, 42, ... (10 calls -> 4).  Not more: the last ones wait to the merge, all the
# pieces held, and their make's tables are made on top of them (benchmarks/perwin61.md)
MEMO_MAKE_ROWS = 1024


class PiecesMemo:
    """pieces_once across calls (the windows of a file, in order): each distinct set of
    candidate inputs (_same_inputs' bytes) is made once, whichever call met it first, so
    K windows make no more rows than one call of all their rows (the rectilinear plate's
    48.6 k lines: 6.2 k rows made at once; in 9 windows each made its own, 13.3 k).
    Every entry is its row's own, so a row has the same entries whichever call made its
    inputs: the new inputs wait until make_rows (None: MEMO_MAKE_ROWS) of them have come (or piece() is asked)
    and are made together, isolate'd: inputs whose make raises fail every row that has
    them into failed (their "planning" error, as each row's own make would).  piece()
    gives the SharedPiece of every row added, the distinct inputs in the order first met:
    the one pieces_once makes of the rows all at once."""

    def __init__(self, failed=None, make_rows=None):
        self.index = _InputsIndex()     # the distinct inputs met, by their bits
        self.rows, self.inv, self.made = [], [], []
        self.failed = {} if failed is None else failed
        self.make_rows = MEMO_MAKE_ROWS if make_rows is None else make_rows
        self.make = self.T_orig = None
        self.waiting, self.waiting_rows = [], []    # the distinct inputs not made yet (PlanInputs), their rows
        self.done = 0           # the distinct inputs made (or lost) so far: the first ids
        self.lost = {}          # {distinct id: why} of the inputs whose make raised

    def add(self, make, p: PlanInput, rows, T_orig):
        """Takes in the rows (p: their PlanInput), the inputs not met before to be made by
        make(p, rows, T_orig) (pieces_once's: the rows' pieces, in order).  False (nothing
        taken) where their inputs are not plain: the caller makes them itself."""
        rows = np.asarray(rows)
        if rows.size == 0:
            return True
        same = _same_inputs(p, max_r=1.0, least=1)
        if same is None:
            return False
        first, inv = same
        known = len(self.index)
        ids = self.index.ids([c[first].view(np.int64) for c in _same_cols(p)])
        fresh = np.flatnonzero(ids >= known)
        if fresh.size:
            self.make, self.T_orig = make, T_orig
            self.waiting.append(p.take(first[fresh]))
            self.waiting_rows.append(rows[first[fresh]])
        self.rows.append(rows)
        self.inv.append(ids[inv])
        if len(self.index) - self.done >= self.make_rows:
            self._make_waiting()
        return True

    def _make_waiting(self):
        """The waiting inputs' pieces made in one call (isolate: those whose make raises
        lost, their first rows failed)."""
        if not self.waiting:
            return
        p, rows = _joined_inputs(self.waiting), np.concatenate(self.waiting_rows)
        self.waiting, self.waiting_rows = [], []
        make, T_orig, whys = self.make, self.T_orig, {}

        def made(at):
            return make(p if at.size == rows.size else p.take(at), rows[at], T_orig)
        for _, got in isolate(made, np.arange(rows.size), "planning", whys):
            self.made += got
        for at, why in whys.items():
            self.lost[self.done + at] = why
            self.failed[int(rows[at])] = why
        self.done += rows.size

    def piece(self):
        """[the SharedPiece of every row added] ([] if none).  The memo is spent: what it
        held (its pieces, the inputs' keys: ~2 MB on the rectilinear plate) is let go, not
        held beside the SharedPiece through the tables' merge."""
        self._make_waiting()
        if not self.rows:
            return []
        rows, inv, made = np.concatenate(self.rows), np.concatenate(self.inv), self.made
        lost = self.lost
        self.index, self.rows, self.inv, self.made, self.lost = _InputsIndex(), [], [], [], {}
        if lost:
            rows, inv = _without_lost(rows, inv, lost, self.done, self.failed)
            if not rows.size:
                return []
        return [_shared_piece(rows, made, inv)]


class _InputsIndex:
    """PiecesMemo's distinct inputs by their bits (rows of int64 columns): ids() gives a row
    met before its id, a new one the next.  Looked up by a hash of the rows (distinct.
    _row_hashes) in a sorted array, each found row compared with the one kept, column by
    column: no bytes object and dict look-up a row in Python (~600 instructions each, the
    ~50 k distinct rows of the rectilinear plate's 11 windowed calls)."""

    def __init__(self):
        self.h = np.zeros(0, np.uint64)        # the rows' hashes, sorted (a hash's rows in the order met)
        self.at = np.zeros(0, np.intp)         # each one's id
        self.cols = None                       # the rows kept, by id: a list of int64 columns

    def __len__(self):
        return self.at.size

    def ids(self, cols):
        """The id of each row of the int64 columns cols (distinct rows): that of the row of
        its bits met before, else the next ones in their order (kept from now on)."""
        h = _row_hashes(cols)
        n = h.size
        ids = np.full(n, -1, np.intp)
        if self.h.size:
            k = np.minimum(np.searchsorted(self.h, h), self.h.size - 1)
            q = np.flatnonzero(self.h[k] == h)
            got = self.at[k[q]]
            same = np.ones(q.size, bool)
            for c, kept in zip(cols, self.cols):
                same &= kept[got] == c[q]
            ids[q[same]] = got[same]
            for j, a in zip(q[~same].tolist(), k[q[~same]].tolist()):   # (another row of that hash first)
                ids[j] = self._twin(cols, j, h[j], a)
        new = np.flatnonzero(ids < 0)
        if new.size:
            ids[new] = len(self) + np.arange(new.size)
            h_all = np.concatenate([self.h, h[new]])
            o = np.argsort(h_all, kind="stable")
            self.h, self.at = h_all[o], np.concatenate([self.at, ids[new]])[o]
            self.cols = [c[new] if kept is None else np.concatenate([kept, c[new]])
                         for c, kept in zip(cols, self.cols or [None] * len(cols))]
        return ids

    def _twin(self, cols, j, h, a):
        """The id of row j of cols among the rows kept of its hash h (from a, the first of
        them), or -1."""
        while a < self.h.size and self.h[a] == h:
            i = self.at[a]
            if all(kept[i] == c[j] for c, kept in zip(cols, self.cols)):
                return i
            a += 1
        return -1


def _without_lost(rows, inv, lost, n, failed):
    """(rows, inv) of a PiecesMemo's rows but those of the lost distinct inputs (of n; {id:
    why}), failed with their why, the others' ids counted without the lost ones."""
    gone = np.zeros(n, bool)
    gone[list(lost)] = True
    out = gone[inv]
    for r, i in zip(rows[out].tolist(), inv[out].tolist()):
        failed.setdefault(r, lost[i])
    keep = ~out
    return rows[keep], (np.cumsum(~gone) - 1).astype(inv.dtype)[inv[keep]]


def _joined_inputs(parts):
    """The PlanInputs parts as one (their rows in turn)."""
    if len(parts) == 1:
        return parts[0]
    return PlanInput(*(np.concatenate([getattr(q, f) for q in parts]) for f in PlanInput.FIELDS))


SAME_MAX_R = 0.8        # _same_inputs: worth it where the distinct strokes are at most this share


def _same_cols(p: PlanInput):
    """The candidate inputs of p that _same_inputs compares (all that _live_entries and
    _live_tables read)."""
    return (p.L, p.v0, p.v1, p.v_cap, p.a_cap, p.T_orig, p.t_seg_min)


def _same_inputs(p: PlanInput, max_r=SAME_MAX_R, least=2):
    """(first, inv): the strokes of p whose candidate inputs (L, v0, v1, v_cap, a_cap,
    T_orig, t_seg_min: all that _live_entries and _live_tables read) are the first
    of their bytes, in order, and each stroke's place among them (p's row q has the
    inputs of row first[inv[q]], bit for bit); None where that is not worth it (fewer than
    1 / SAME_MAX_R strokes a set of inputs) or the inputs are not plain (_live_entries:
    every chunk then takes the live path, whose entries are each row's own, as they
    are in any chunk).  max_r: the largest share of distinct strokes worth it; least: the
    fewest strokes.  The rectilinear plate's 48.6 k lines have 6.2 k sets of inputs
    (the layers of a prism repeat their perimeters and infill: its line candidates ~0.16
    -> ~0.06 s); the gyroid plate's 13.8 k have 6.7 k, too many to pay (schedule's
    _lines_repeat: no pieces_once there)."""
    n = len(p.L)
    if n < least:
        return None
    cols = _same_cols(p)
    if not all(type(c) is np.ndarray and c.dtype == _F64 and c.shape == (n,) for c in cols):
        return None
    if not _plain(p):
        return None
    # by their bytes (-0.0 and 0.0 apart), hashed column by column (column_classes: np.unique
    # of the rows as 56-byte records sorted them by memcmp, ~10 ms on the rectilinear plate)
    first, inv = classes_in_row_order([c.view(np.int64) for c in cols])
    return None if first.size > max_r * n else (first, inv)


def _plain(p: PlanInput):
    """_live_entries' test of plain inputs on the (n, k) durations T_orig x T_RATIOS, made
    on their least and largest columns only: a product by a constant > 0, the quotient
    and the square round monotonically, so a row's least (greatest) duration and its
    square are those of its least (largest) ratio, and every duration is finite and > 0,
    and squares to > 0, where those are (a NaN fails both ways)."""
    T = p.T_orig[:, None] * T_RATIOS[None, [int(np.argmin(T_RATIOS)), int(np.argmax(T_RATIOS))]]
    with np.errstate(all="ignore"):
        return bool(np.isfinite(T).all() and (T > 0).all() and np.isfinite(p.L).all()
                    and np.isfinite(p.v0).all() and np.isfinite(p.v1).all()
                    and ((T[:, 0] / (2.0 * GAMMA_HI)) ** 2 > 0.0).all())


def _chunk_tables(p: PlanInput, chunk):
    """(first row, end row, (T, beta, I, KE) of those rows) chunk by chunk, in order (see
    candidates_auto)."""
    n = len(p.L)
    step = chunk * BISECT_CHUNKS
    for a0 in range(0, n, step):
        chunks = [np.arange(a, min(a + chunk, n)) for a in range(a0, min(a0 + step, n), chunk)]
        live = [_live_entries(p.take(rows)) for rows in chunks]
        betas = _beta_search([lv[1] for lv in live if lv is not None])
        # each chunk's state and dense tables let go once used: all the chunks' states, and
        # the last chunk's tables beside the next one's, were held to the end (gyroid
        # plate's lines: the candidates' peak)
        live = [None if lv is None else lv[0] for lv in live]      # (their flat positions)
        for c, rows in enumerate(chunks):
            flat, live[c] = live[c], None
            q = p.take(rows)
            tables = _candidates_dense(q) if flat is None else _live_tables(q, flat, *next(betas))
            del flat, q
            yield rows[0], rows[-1] + 1, tables      # (a run of rows: a slice, not an index)
            tables = None


BISECT_CHUNKS = 8       # candidates_auto: chunks whose bisections are made at once


def _candidates_auto(p: PlanInput):
    """_candidates_dense's tables, computed only where a law can be within limits: a
    candidate shorter than the stroke's t_seg_min is infeasible whatever its beta (~78 %
    of the gyroid plate's), and so is one whose length is out of reach (out_of_reach:
    a quarter of the rectilinear plate's others), so neither its beta, its law nor its
    figures are made; its entries are I = inf, beta = inf, KE = nan (the allocation reads
    only the feasible ones: Candidates keeps those).  Every feasible entry's T, beta, I
    and KE, and which are feasible, are _candidates_dense's, bit for bit: every step is
    elementwise (tests/test_speed22_budget_candidates.py,
    tests/test_speed24_lineplan_candidates.py).  Inputs on which _candidates_dense could
    raise (a duration not finite and > 0, a length or end speed not finite, a beta the
    bisection tries underflowing to 0) go to _candidates_dense itself."""
    lv = _live_entries(p)
    if lv is None:
        return _candidates_dense(p)
    return _live_tables(p, lv[0], *next(_beta_search([lv[1]])))


def _live_entries(p: PlanInput):
    """A chunk's live entries, before the bisection: (flat positions in the (n, k)
    tables (int32), _beta_prep's state), or None where the inputs are not plain (see
    _candidates_auto)."""
    T = p.T_orig[:, None] * T_RATIOS[None, :]
    with np.errstate(all="ignore"):
        plain = (np.isfinite(T).all() and bool((T > 0).all()) and np.isfinite(p.L).all()
                 and np.isfinite(p.v0).all() and np.isfinite(p.v1).all()
                 and bool(((T / (2.0 * GAMMA_HI)) ** 2 > 0.0).all()))
    if not plain:
        return None
    flat = np.flatnonzero(T >= p.t_seg_min[:, None])
    r = flat // T.shape[1]
    # (take: numpy's plain gather loop, fewer steps an item than indexing; the same values)
    Tq = T.ravel().take(flat)
    L, v0, v1, v_cap, a_cap = (a.take(r) for a in (p.L, p.v0, p.v1, p.v_cap, p.a_cap))
    # entries no law can meet (a quarter of a plate's live ones, two thirds of those the
    # bisection would take) are infeasible whatever beta: left as the others above
    reach = ~out_of_reach(L, Tq, v0, v1, v_cap, a_cap)
    if not reach.all():
        q = np.flatnonzero(reach)            # (the mask's places once, not a mask gather an array)
        flat, Tq, L, v0, v1, v_cap = (x.take(q) for x in (flat, Tq, L, v0, v1, v_cap))
    return flat.astype(np.int32), _beta_prep(L, Tq, v0, v1, v_cap)


def _live_tables(p: PlanInput, flat, bq, v_crit):
    """The (T, beta, I, KE) tables of the chunk p from its live entries (flat positions)
    and their beta and interior speed (_beta_search)."""
    T = p.T_orig[:, None] * T_RATIOS[None, :]
    shape = T.shape
    beta = np.full(shape, np.inf)
    I = np.full(shape, np.inf)
    KE = np.full(shape, np.nan)
    if not flat.size:
        return T, beta, I, KE
    r = flat // shape[1]
    Tq = T.ravel().take(flat)
    L, v0, v1, v_cap, a_cap = (a.take(r) for a in (p.L, p.v0, p.v1, p.v_cap, p.a_cap))
    # the law's peak acceleration and integrals: the cubic ones (beta = inf, ~94 % of the
    # rectilinear plate's) by cubic_figures, the others by their LineLaw (each entry its own)
    a_peak, KEq, Iq = _law_figures(L, Tq, bq, v0, v1)
    # _feasible(law, v_cap, a_cap) (T >= t_seg_min: every live entry), its speeds at the
    # ends and at the interior extremum those the law's _speed_candidates gives (end_speeds,
    # InteriorSpeeds: the same bits), in the same order
    speeds = (*end_speeds(L, Tq, v0, v1), v_crit)
    ok = ((np.maximum.reduce(speeds) <= v_cap * (1 + SPEED_TOL_R)) & (a_peak <= a_cap * (1 + SPEED_TOL_R))
          & (np.minimum.reduce(speeds) >= -1e-9 * (1 + v_cap)))
    beta.ravel()[flat] = bq
    I.ravel()[flat] = np.where(ok, Iq, np.inf)
    KE.ravel()[flat] = KEq
    return T, beta, I, KE


def _law_figures(L, T, beta, v0, v1):
    """(peak_accel(), int_v2, int_a2) of line_law(L, T, beta, v0, v1) (1-D, plain inputs
    as _live_entries checks them): cubic_figures where beta = inf, the LineLaw of the
    others.  The same bits: a law's figures are its own (elementwise; the series' term
    counts of the others' batch are set by its largest gamma^2, and the cubic ones' are 0)."""
    cubic = beta == np.inf
    if not cubic.any():
        law = line_law(L, T, beta, v0, v1)
        return (law.peak_accel(), *law.integrals())
    if cubic.all():
        return cubic_figures(L, T, v0, v1)
    out = [np.empty(L.shape) for _ in range(3)]
    c, o = np.flatnonzero(cubic), np.flatnonzero(~cubic)
    for x, y in zip(out, cubic_figures(L[c], T[c], v0[c], v1[c])):
        x[c] = y
    law = line_law(L[o], T[o], beta[o], v0[o], v1[o])
    for x, y in zip(out, (law.peak_accel(), *law.integrals())):
        x[o] = y
    return tuple(out)


REACH_TOL_R = 1e-6     # out_of_reach's margins: far above the rounding of the law's figures (~1e-15)


def out_of_reach(L, T, v0, v1, v_cap, a_cap):
    """Which strokes (elementwise) no law of duration T can take within the caps: length
    L beyond the farthest any motion from v0 to v1 in T goes with speed <= v_cap and |a|
    <= a_cap (ramp up at a_cap, cruise at v_cap, ramp down: a trapezoid, or a triangle
    when there is no time to reach v_cap).  A law is such a motion: it covers L exactly,
    its peak |a| is at an end (LineLaw.peak_accel) and its peak speed at an end or at its
    one interior extremum, the values _feasible compares.  So where L exceeds that reach
    by a clear margin, _feasible fails for every beta: the speed or the acceleration
    computed is over its cap (with SPEED_TOL_R), whatever the rounding (~1e-15 of those
    figures, against the margins of REACH_TOL_R).  False wherever the bound does not
    apply (an end speed over the cap or below 0, an end-speed change beyond a_cap T) or
    an input is not finite: those entries are computed as before."""
    with np.errstate(all="ignore"):
        v_top = v_cap * (1 + SPEED_TOL_R) * (1 + REACH_TOL_R)
        a_top = a_cap * (1 + SPEED_TOL_R) * (1 + REACH_TOL_R)
        up_t, down_t = (v_top - v0) / a_top, (v_top - v1) / a_top
        trapezoid_d = v_top * T - (v_top - v0) ** 2 / (2 * a_top) - (v_top - v1) ** 2 / (2 * a_top)
        v_peak = (a_top * T + v0 + v1) / 2
        triangle_d = (v_peak * v_peak - v0 * v0) / (2 * a_top) + (v_peak * v_peak - v1 * v1) / (2 * a_top)
        reach_d = np.where(up_t + down_t <= T, trapezoid_d, triangle_d)
        bound = ((v0 >= 0) & (v1 >= 0) & (v0 <= v_top) & (v1 <= v_top) & (np.abs(v1 - v0) <= a_top * T)
                 & np.isfinite(reach_d) & np.isfinite(L) & np.isfinite(v_top * T))
        return bound & (L - reach_d > REACH_TOL_R * (L + v_top * T))


def _largest_beta_plain(L, T, v0, v1, v_cap):
    """(beta, interior_speed of the law at that beta), beta being gamma_v (see
    _largest_beta_under_speed_cap) of 1-D laws on which the search cannot raise
    (_plain_laws), by _log_gamma_root, with what does not depend on beta made once
    (laws/line.InteriorSpeeds) and the laws whose cubic is under the cap left out."""
    L, T, v0, v1, v_cap = (np.asarray(a, float) for a in (L, T, v0, v1, v_cap))
    return next(_beta_search([_beta_prep(L, T, v0, v1, v_cap)]))


def _beta_prep(L, T, v0, v1, v_cap):
    """_largest_beta_plain up to its search: (v_crit at beta = inf, the rows b whose
    cubic is over the cap, their T, cap, end speed and InteriorSpeeds)."""
    cap = v_cap * (1 + SPEED_TOL_R)
    v_end = np.maximum(*end_speeds(L, T, v0, v1))
    speeds = InteriorSpeeds(L, T, v0, v1)
    v_crit = speeds.cubic()                   # speeds(inf), the same bits
    b = np.flatnonzero(~(np.maximum(v_end, v_crit) <= cap))
    return v_crit, b, T[b], cap[b], v_end[b], speeds.take(b)


def _beta_search(preps):
    """(beta, v_crit) of each _beta_prep state, in turn (an iterator): the root searches
    (_log_gamma_root) of all their rows b at once (each row its own steps, elementwise:
    the same bits as one state at a time); a row left out (cubic under the cap) has
    beta = inf.  v_crit of a searched row is its speed at its beta, the one the search's
    own test of that beta computed (the same expressions on the same numbers).  preps (a
    list): each state is cut to its (v_crit, b) once searched (its searched rows' inputs
    let go where the caller holds the list only)."""
    sizes = [pr[1].size for pr in preps]
    if sum(sizes):
        Tb, capb, v_endb = (np.concatenate([pr[k] for pr in preps]) for k in (2, 3, 4))
        y, v_crit_b = _log_gamma_root(InteriorSpeeds.concat([pr[5] for pr in preps]), Tb, capb, v_endb)
        beta_b = (Tb / np.exp(y)) ** 2
        del Tb, capb, v_endb, y
    # the searched rows' inputs let go (each state's v_crit and rows b only are read below;
    # the list the caller gave is emptied of the others)
    preps[:] = [pr[:2] for pr in preps]
    at = 0
    for pr, m in zip(preps, sizes):
        v_crit, b = pr[0], pr[1]
        out = np.full(v_crit.shape, np.inf)
        if m:
            out[b] = beta_b[at:at + m]
            v_crit[b] = v_crit_b[at:at + m]
            at += m
        yield out, v_crit


_Y_LO, _Y_HI = np.log(GAMMA_LO), np.log(GAMMA_HI)
BISECT_STEPS = 32       # the halvings of (_Y_LO, _Y_HI] whose end _log_gamma_root finds
# the root's estimate: points by the model and secants, settled where a secant step is under
# ROOT_SETTLED_Y (its point then within ~1e-10 of the root: the error falls superlinearly,
# ~ the product of the last two steps, the first ~1e-4) or the bracket under the bisection's
# last width.  On the plates the second point settles (1e-5 .. 3e-6: 4.0 evaluations a law
# with the checks; 1e-6: 4.2; 3e-7: 4.6)
ROOT_SETTLED_Y = 3e-6
ROOT_TOL_Y = (_Y_HI - _Y_LO) * 2.0 ** -BISECT_STEPS
ROOT_MODEL_STEPS = 8    # points a law's estimate may take; then (or if its check fails) the bisection


def _log_gamma_root(speeds, T, cap, v_end):
    """(y, v): for each law of speeds (InteriorSpeeds, 1-D; T its durations, finite > 0 with
    (T / (2 GAMMA_HI))^2 > 0; cap, v_end its cap and larger end speed) the upper end y of
    the bracket on log gamma that BISECT_STEPS halvings of (_Y_LO, _Y_HI] leave, testing
    max(v_end, interior speed) <= cap at each middle (the speed falls as gamma grows), and
    v the interior speed at beta = (T / e^y)^2: the bisection's bits, with ~4 speed
    evaluations a law where it made 33.

    The root is estimated first (_root_estimates), then the bisection's path through the
    estimate is replayed without evaluating (_bisection_path: its middles are the same
    numbers) and checked at its last bracket's two ends: the upper passes, the lower fails
    (an end the bisection never tests, _Y_LO or _Y_HI, is not checked).  Where the test is
    monotone in y, the bisection's every test then goes as the replay's (each middle is at
    or past one of those ends), so its end is the replay's.  A check that fails (0.3 - 0.5 %
    of the plates' laws, estimates ~1e-10 from a middle) replays the path through the side it
    tells (_checked_path); a law still unchecked then takes the bisection itself."""
    y_hi = np.full(T.shape, _Y_HI)
    v_hi = np.empty(T.shape)
    # a law whose end speed is over the cap fails every test: the bisection's end is _Y_HI
    rows = np.flatnonzero(v_end <= cap)
    if rows.size < T.size:
        over = np.flatnonzero(~(v_end <= cap))
        v_hi[over] = speeds.take(over)((T[over] / np.exp(y_hi[over])) ** 2)
    if rows.size:
        y_hi[rows], v_hi[rows] = _checked_path(speeds.take(rows), T[rows], cap[rows], v_end[rows])
    return y_hi, v_hi


def _checked_path(sp, T, cap, v_end):
    """_log_gamma_root of laws whose end speed is under the cap: (y, v).  A check that fails
    tells on which side of its bracket the root is: the path is replayed through that side
    (PATH_CHECKS times at most, then the bisection)."""
    y, v = np.empty(T.shape), np.empty(T.shape)
    est = _root_estimates(sp, T, cap, v_end)
    todo = np.arange(T.size)
    for _ in range(PATH_CHECKS):
        lo, hi = _bisection_path(est)
        v_hi = sp((T / np.exp(hi)) ** 2)
        hi_ok = (np.maximum(v_end, v_hi) <= cap) | (hi == _Y_HI)
        lo_ok = np.zeros(T.shape, bool)
        at = np.flatnonzero(lo > _Y_LO)
        lo_ok[at] = _passes(sp.take(at), T[at], cap[at], v_end[at], lo[at])
        good = hi_ok & ~lo_ok
        y[todo[good]], v[todo[good]] = hi[good], v_hi[good]
        bad = np.flatnonzero(~good)
        if not bad.size:
            return y, v
        # the root is past hi where hi fails (a middle equal to hi then fails), at or before lo where lo passes
        est = np.where(hi_ok, lo, np.nextafter(hi, np.inf))[bad]
        todo, sp, T, cap, v_end = todo[bad], sp.take(bad), T[bad], cap[bad], v_end[bad]
    y[todo] = _bisect_rows(sp, T, cap, v_end)
    v[todo] = sp((T / np.exp(y[todo])) ** 2)
    return y, v


PATH_CHECKS = 3         # _checked_path: replays of a law's path before the bisection itself


def _passes(sp, T, cap, v_end, y):
    """The bisection's test of the laws sp at log gamma y."""
    return np.maximum(v_end, sp((T / np.exp(y)) ** 2)) <= cap


def _bisection_path(y_root):
    """(lo, hi) that the bisection leaves when every middle at or past y_root passes and
    every other fails (a NaN root: every middle fails)."""
    return _halvings(lambda mid: mid >= y_root, y_root.shape)


def _bisect_rows(sp, T, cap, v_end):
    """The bisection's upper end for the laws sp, by the bisection."""
    return _halvings(lambda mid: _passes(sp, T, cap, v_end, mid), T.shape)[1]


def _halvings(passes, shape):
    """(lo, hi) after BISECT_STEPS halvings of (_Y_LO, _Y_HI], the upper half kept where
    passes(middle) (the bisection's arithmetic, bit for bit)."""
    lo = np.full(shape, _Y_LO)
    hi = np.full_like(lo, _Y_HI)
    for _ in range(BISECT_STEPS):
        mid = 0.5 * (lo + hi)
        ok = passes(mid)
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    return lo, hi


def _root_estimates(sp, T, cap, v_end):
    """Each law's estimate of the least log gamma passing the bisection's test (NaN where
    none settles in ROOT_MODEL_STEPS points): the model's root (laws/line.peak_root_guess),
    a Newton step with the model's slope, then secants on the true residual, each point
    kept inside the bracket the points so far make (_inside)."""
    est = np.full(T.shape, np.nan)
    rows = np.arange(T.size)
    lo, hi = np.full(T.shape, _Y_LO), np.full(T.shape, _Y_HI)
    with np.errstate(divide="ignore", invalid="ignore"):          # (A = 0: NaN, the bracket's middle)
        r_of_v = T / sp.A                    # residual in the model's units: P - w = (v - cap) T / A
        y, slope = peak_root_guess(sp.rho * sp.rho, (cap * T - sp.wbar) / sp.A)
    y_last = r_last = None
    for step in range(1, ROOT_MODEL_STEPS + 1):
        y = _inside(y, lo, hi)
        v = sp((T / np.exp(y)) ** 2)
        ok = np.maximum(v_end, v) <= cap
        hi, lo = np.where(ok, y, hi), np.where(ok, lo, y)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            r = (v - cap) * r_of_v
            y_next = y - r / slope if y_last is None else y - r * (y - y_last) / (r - r_last)
        settled = hi - lo <= ROOT_TOL_Y
        if step > 1:
            settled |= np.abs(y_next - y) < ROOT_SETTLED_Y
        done = np.flatnonzero(settled)
        if done.size:
            y_in = y_next[done]
            lo_d, hi_d = lo[done], hi[done]
            est[rows[done]] = np.where((y_in > lo_d) & (y_in <= hi_d), y_in, 0.5 * (lo_d + hi_d))
            keep = np.flatnonzero(~settled)
            if not keep.size:
                break
            rows, sp = rows[keep], sp.take(keep)
            T, cap, v_end, r_of_v, lo, hi, y, r, y_next = (
                a[keep] for a in (T, cap, v_end, r_of_v, lo, hi, y, r, y_next))
        y_last, r_last, y = y, r, y_next
    return est


def _inside(y, lo, hi):
    """The point y where it is inside (lo, hi); past an end still untested (_Y_LO, _Y_HI:
    the root may be out of the range), that end; else the bracket's middle (NaN too); kept
    ROOT_TOL_Y / 2 from both ends."""
    y = np.where((y > lo) & (y < hi), y, np.where((y >= hi) & (hi == _Y_HI), hi,
                                                  np.where((y <= lo) & (lo == _Y_LO), lo, 0.5 * (lo + hi))))
    return np.minimum(np.maximum(y, lo + 0.5 * ROOT_TOL_Y), hi - 0.5 * ROOT_TOL_Y)


def _candidates_dense(p: PlanInput):
    """Every candidate's T, beta, I, KE (the start commit's _candidates_auto): the path of
    inputs on which a law or the bisection may raise."""

    T = p.T_orig[:, None] * T_RATIOS[None, :]
    L, v0, v1 = p.L[:, None], p.v0[:, None], p.v1[:, None]
    v_cap, a_cap = p.v_cap[:, None], p.a_cap[:, None]
    beta = _largest_beta_under_speed_cap(L, T, v0, v1, v_cap)
    law = line_law(L, T, beta, v0, v1)
    ok = _feasible(law, v_cap, a_cap) & (T >= p.t_seg_min[:, None])
    KE, I = law.integrals()
    return T, beta, np.where(ok, I, np.inf), KE


def allocate(T, I, T_orig, I_orig, budget_t):
    """Pick one candidate per stroke (or the original: column -1 of the extended arrays)
    minimising sum I + lambda sum T with sum (T - T_orig) <= budget_t.

    Bisection on lambda (80 halvings), each step the choice of every stroke.  A stroke's
    choice is the lower envelope of its candidates' lines I + lambda T: once it is the same
    at both ends of the bracket with a clear margin there (the margin to the next
    candidate is concave in lambda, so it is least at an end), it is that one inside the
    whole bracket, and later steps take it as known instead of computing it again.  Each
    step's total time is still summed over every stroke as before: the same choices, the
    same sums, the same bits as evaluating every stroke at every step."""
    Tx = np.concatenate([T, T_orig[:, None]], axis=1)
    Ix = np.concatenate([I, I_orig[:, None]], axis=1)
    finite = np.isfinite(Ix)
    # the margin test needs costs that add two non-negative terms (no cancellation);
    # otherwise every stroke is evaluated at every step
    settle = bool(np.all(Ix[finite] >= 0.0) and np.all(Tx >= 0.0))
    return _allocate(Tx, Ix, finite, T_orig, budget_t, settle)


def _allocate(Tx, Ix, finite, T_orig, budget_t, settle):
    """allocate on its extended tables (the original as the last column); settle: the
    costs cannot cancel (every finite I and every T >= 0), so the margin test holds.

    Where every T is finite and >= 0 ("plain"), Ix's entries that are not finite are set
    to inf in place: inf + lambda T is then the inf the choice gave them (lambda is
    finite), and the cost needs no mask.  Then the rows with at most NARROW_COLS finite
    candidates (most: a line has its original and ~5 laws of 24 columns) are costed on
    narrow tables holding their finite entries first, in column order: the same costs,
    the same least (argmin's first, mapped back to its column) and the same second least
    (the rest are inf in both), so the same choices and margins.  With the compiled core
    (firmware/_core.c's alloc_choices), plain tables are costed row by row in one call a
    step instead, with the same operations (a product, then a sum), argmin's first, the
    same second least, margins and T - T_orig.  Rows with at most one finite candidate
    (a third of a plate's) take it once: it is their choice at every lambda."""
    n, k = Ix.shape
    rows = np.arange(n)
    plain = bool(n and np.isfinite(Tx).all() and Tx.min() >= 0.0)
    narrow = core = None
    if plain:
        Ix[~finite] = np.inf
        core = _alloc_core() if k >= 2 else None
        if core is not None:      # a row's costs in one compiled pass (same ops, same order)
            Tx, Ix = np.ascontiguousarray(Tx, float), np.ascontiguousarray(Ix, float)
            T_orig = np.ascontiguousarray(T_orig, float)
        else:
            narrow = _narrow_tables(Tx, Ix, finite)
    # each stroke's T - T_orig at its current choice, kept row by row as choices change:
    # the same array, so the same sum, as taking every row's again at each step
    dT = np.empty(n)

    def take(j, r):
        dT[r] = Tx[r, j] - T_orig[r]

    def step(lam, r):
        """choices(lam, r), and take() of them (the compiled core's call takes them)."""
        got = choices(lam, r)
        if core is None:
            take(got[0], r)
        return got

    def spent():
        return float(np.sum(dT))

    def dense(lam, r):
        m = len(r)
        if not plain:
            cost = np.where(finite[r], Ix[r] + lam * Tx[r], np.inf)
        elif m and r[-1] - r[0] + 1 == m:          # a run of rows: views, not copies
            cost = Ix[r[0]:r[0] + m] + lam * Tx[r[0]:r[0] + m]
        else:
            cost = Ix[r] + lam * Tx[r]
        j = np.argmin(cost, axis=1)
        if k < 2:                 # one candidate: it cannot change
            return j, np.full(m, np.inf), np.zeros(m)
        ar = np.arange(m)
        c1 = cost[ar, j]
        if np.isnan(c1).any():    # argmin stops at a NaN: sort as before
            two = np.partition(cost, 1, axis=1)
            c1, c2 = two[:, 0], two[:, 1]
        else:                     # the second least: the least once the least is taken out
            cost[ar, j] = np.inf
            c2 = np.min(cost, axis=1)
        return j, c1, c2

    def thin(lam, r):
        """dense() of rows r, all narrow; None where a least cost is inf (no finite
        candidate, or an overflow: argmin's first inf may be another column).  The
        narrow tables are column-major (w, rows): the least (argmin's first: a later
        column replaces it only where strictly less) and the second least (the least
        of the others, a tie included) are kept column by column, elementwise, on
        arrays of rows instead of reductions along rows of w entries.  The costs hold
        no NaN (finite T >= 0, finite lambda, I finite or inf), so these are argmin's
        and min's choices and values; only the sign of a zero second least may differ,
        which only comparisons and abs() read."""
        is_n, pos, col, Tn, In = narrow
        p = pos[r]
        cost = In[:, p]
        cost += lam * Tn[:, p]
        jn, c1, c2 = _least_two(cost)
        if np.isinf(c1).any():
            return None
        return col[p, jn].astype(np.intp), c1, c2

    def block(lam, r):
        if narrow is not None:
            nr = narrow[0][r]
            if nr.all():
                got = thin(lam, r)
                if got is not None:
                    return got
            elif nr.any():
                a, b = thin(lam, r[nr]), dense(lam, r[~nr])
                if a is not None:
                    return tuple(_merge(nr, x, y) for x, y in zip(a, b))
        return dense(lam, r)

    def choices(lam, r):
        """Choice and margin to the next candidate of rows r at lam (margin inf where only
        one candidate is finite or none is: then the choice cannot change).  By blocks of
        rows, so that the cost matrices stay small (row-wise: the same numbers).  Narrow
        rows go by blocks of NARROW_ROWS (thin's arrays are a row's 8 columns, not 24:
        fewer, larger numpy calls), the others by ALLOCATE_ROWS; a narrow block thin()
        declines goes by ALLOCATE_ROWS as before.  With the compiled core (plain tables),
        all rows in one call of alloc_choices: the same values row by row."""
        if core is not None:
            r = np.ascontiguousarray(r, np.intp)
            j, margin, tol = np.empty(r.size, np.intp), np.empty(r.size), np.empty(r.size)
            core.alloc_choices(Tx, Ix, k, r, lam, MARGIN_R, T_orig, dT, j, margin, tol)   # and take(j, r)
            return j, margin, tol
        if narrow is not None and len(r) > ALLOCATE_ROWS:
            nr = narrow[0][r]
            if nr.all():
                if len(r) > NARROW_ROWS:
                    parts = [choices(lam, r[a:a + NARROW_ROWS]) for a in range(0, len(r), NARROW_ROWS)]
                    return tuple(np.concatenate(x) for x in zip(*parts))
                got = thin(lam, r)
                if got is not None:
                    return margins(*got)
            elif nr.any():
                return tuple(_merge(nr, x, y) for x, y in zip(choices(lam, r[nr]), choices(lam, r[~nr])))
        if len(r) > ALLOCATE_ROWS:
            parts = [choices(lam, r[a:a + ALLOCATE_ROWS]) for a in range(0, len(r), ALLOCATE_ROWS)]
            return tuple(np.concatenate(x) for x in zip(*parts))
        return margins(*block(lam, r))

    def margins(j, c1, c2):
        if k < 2:
            return j, c1, c2
        with np.errstate(invalid="ignore"):
            margin = np.where(np.isinf(c2), np.inf, c2 - c1)
        return j, margin, MARGIN_R * (np.abs(c1) + np.abs(c2))

    # rows with at most one finite candidate keep one choice at every lambda (the others'
    # costs are inf; where costs cannot overflow): their choice and T - T_orig are taken
    # once, and the steps below cost and sum only the others
    # choices() calls itself: its closure is a reference cycle holding Tx and Ix (~13 MB on
    # the gyroid plate) until the cyclic collector runs; cut when the allocation is done
    try:
        live = rows
        J = np.empty(n, np.intp)      # every stroke's choice; those of `act` are the bracket's ends'
        if plain and k >= 2:
            fixed = np.flatnonzero(finite.sum(axis=1) <= 1)
            j1 = np.argmax(finite[fixed], axis=1)                # none finite: argmin's 0
            fixed, j1 = _fixed(Tx, Ix, finite, fixed, j1)
            if fixed.size:
                one = np.zeros(n, bool)
                one[fixed] = True
                live = np.flatnonzero(~one)
                J[fixed] = j1
                take(j1, fixed)
        return _bisect(J, live, step, spent, budget_t, settle)
    finally:
        choices = None


def _bisect(J, live, step, spent, budget_t, settle, rise=None):
    """_allocate's bisection on lambda over the rows live (J: every row's choice, the
    others' set already), step(lam, rows) -> (choice, margin, tol) of those rows (and
    their T - T_orig taken), spent() the sum of every row's.  rise (_Rise, or None): the
    decade search's choices by it, and only its last decade's margins and tols by step.
    The rows whose choice changes within TIE_R above the lambda found take the choice
    above it (_break_ties).  Returns (J, lambda)."""
    j_lo, m_lo, _ = step(0.0, live) if rise is None else rise.start(step, live)
    if spent() <= budget_t:
        J[live] = j_lo
        return J, 0.0
    lo, hi = 0.0, 1.0
    while True:
        if rise is None:
            j_hi, m_hi, tol_hi = step(hi, live)
        else:
            rise(hi)
        if not (spent() > budget_t and hi < 1e30):
            break
        hi *= 10.0
    if rise is not None:      # the last decade's margins and tols (its choices are rise's)
        j_hi, m_hi, tol_hi = rise.last(hi)
    J[live] = j_hi
    act = live
    brackets = []       # (lo, hi, act) of the late steps: where _break_ties looks for its rows
    for _ in range(80):
        # the costs grow with lambda (T >= 0): the rounding anywhere in the bracket is
        # at most the top end's, tol_hi, which both margins must clear
        keep = (j_lo != j_hi) | ~(m_lo > tol_hi) | ~(m_hi > tol_hi)
        if settle and not keep.all():        # settled: J holds their choice for the rest of the bisection
            q = np.flatnonzero(keep)         # (the mask's places once, then a take an array)
            act, j_lo, m_lo, j_hi, m_hi, tol_hi = (a.take(q) for a in (act, j_lo, m_lo, j_hi, m_hi, tol_hi))
        if hi - lo <= TIE_KEEP_R * hi:
            brackets.append((lo, hi, act))
        mid = 0.5 * (lo + hi)
        j_mid, m_mid, tol_mid = step(mid, act)
        J[act] = j_mid
        if spent() > budget_t:
            lo, j_lo, m_lo = mid, j_mid, m_mid
        else:
            hi, j_hi, m_hi, tol_hi = mid, j_mid, m_mid, tol_mid
    J[act] = j_hi
    _break_ties(J, live, brackets, hi, step, spent, budget_t)
    return J, hi


TIE_R = 1e-9           # choices changing within this above the lambda found are ties: all take the faster
TIE_KEEP_R = 1e-6      # _bisect keeps its brackets (and their rows) once narrower than this, relative


def _break_ties(J, live, brackets, lam, step, spent, budget_t):
    """The choices of the rows whose choice changes within TIE_R above lam (relative) at
    lam (1 + TIE_R): the same strokes on two copies of an object have switch points equal
    to rounding, and those the bisection left at the slower choice would follow that
    rounding; all of them take the faster one, as the same rows (a group) do at lam.  The
    rows whose choice changes in the window: among those not settled in the last bracket
    of `brackets` holding it (a settled row's choice is constant there), else among live.
    Where no other row changes there (the usual case) the choices are the bisection's.
    (The rows hold the last step's: _RowSpread takes more rows than it had as others.)"""
    lam_b = lam * (1.0 + TIE_R)
    rows = next((a for lo, hi, a in reversed(brackets) if lo <= lam and hi >= lam_b), live)
    jb = step(lam_b, rows)[0]
    if spent() <= budget_t:           # (the budget holds at lam_b: choices fall as lambda rises)
        J[rows] = jb


NARROW_COLS = 8        # allocate: rows with at most this many finite candidates go narrow
GROUP_R = 0.5          # _allocate_rows allocates by groups of same rows when at most this share are distinct
                       # (beyond, its copies of the groups' figures and row lists cost more than they save)

PACK_ROWS = 8192       # _RowsView.columns: rows whose running counts are made at once
CHECK_ENTRIES = 1 << 16   # Candidates.rows_view: entries checked at once


class _RowsView:
    """Candidates.rows_view's: first, cnt (intp): each row's first entry in vals and how
    many (its original is then at column cnt); T_orig, I_orig of the rows; settle as
    allocation_tables finds it; reps, inv (intp): _same_rows' groups of the rows, None
    where there are more than GROUP_R of the rows (each row is then its own group)."""
    __slots__ = ("first", "cnt", "T_orig", "I_orig", "settle", "reps", "inv")

    def __init__(self, first, cnt, T_orig, I_orig, settle):
        self.first = np.ascontiguousarray(first, np.intp)
        self.cnt = np.ascontiguousarray(cnt, np.intp)
        self.T_orig, self.I_orig, self.settle = T_orig, I_orig, settle
        self.reps = self.inv = None
        if _firsts_at_most(self.first, GROUP_R * self.cnt.size):
            self.reps, self.inv = _same_rows(self.first, self.cnt, T_orig, I_orig)
            if self.reps.size > GROUP_R * self.cnt.size:
                self.reps = self.inv = None

    def columns(self, mask_rows, j, k):
        """The dense columns (mask_rows: the rows' mask; k: the original) of the choices j
        (a row's j-th candidate, cnt = its original)."""
        out = np.full(j.size, k, np.intp)
        q = np.flatnonzero(j < self.cnt)
        for a in range(0, q.size, PACK_ROWS):
            qq = q[a:a + PACK_ROWS]
            # the (j + 1)-th feasible column of each row: the first whose running count passes j
            run = np.cumsum(mask_rows[qq], axis=1, dtype=np.int8)
            out[qq] = np.argmax(run > j[qq, None], axis=1)
        return out


def _firsts_at_most(first, most):
    """Are there at most `most` distinct values in first (intp, >= 0)?  The rows of a
    group share their first, so more of them means more groups than that: _same_rows'
    sort is then not made (the gyroid plate: +40 M instructions for groups declined)."""
    if first.size == 0:
        return True
    seen = np.zeros(int(first.max()) + 1, bool)
    seen[first] = True
    return np.count_nonzero(seen) <= most


def _same_rows(first, cnt, T_orig, I_orig):
    """The rows' groups of the same entries (first, cnt) and the same originals (their
    bits): every row of a group has the same costs at every lambda, so the same choice,
    margins and T - T_orig (lines that repeat share their entries: SharedPiece).  Returns
    (reps: each group's first row, ascending; inv: each row's group)."""
    if first.size == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    return classes_in_row_order([I_orig.view(np.int64), T_orig.view(np.int64), cnt, first])


def _allocate_rows(vals, rv, budget_t, core):
    """_allocate's choices on the candidates where they are (Candidates.rows_view) by the
    compiled core's alloc_rows: each row's costs are its feasible candidates' and its
    original's in the dense order, so argmin's first, the second least, the margins and
    T - T_orig are the dense tables' (the columns left out cost inf at every lambda and no
    least cost is inf: rows_view declines tables where one could be).  Each group of rows
    with the same costs (rv.reps, rv.inv) is allocated once, by its first row: its rows
    settle together and keep the same values through the bisection, and every row's T -
    T_orig is kept in one array in row order (_RowSpread), so the sums are the same.
    Returns (choice per row: its j-th candidate, cnt = its original; lambda)."""
    reps, inv = rv.reps, rv.inv
    vT, vI = np.ascontiguousarray(vals[0]), np.ascontiguousarray(vals[2])
    first, cnt, T_orig, I_orig = ((rv.first, rv.cnt, rv.T_orig, rv.I_orig) if reps is None else
                                  (a.take(reps) for a in (rv.first, rv.cnt, rv.T_orig, rv.I_orig)))
    J = np.empty(cnt.size, np.intp)
    spread = _RowSpread(inv, cnt.size)
    # groups with no candidate keep their original (column 0) at every lambda
    fixed = np.flatnonzero(cnt == 0)
    J[fixed] = 0
    spread.dT_u[fixed] = T_orig[fixed] - T_orig[fixed]
    live = np.flatnonzero(cnt != 0)
    tables = (vT, vI, first, cnt, T_orig, I_orig)

    def step(lam, g, ref=None):
        j, margin, tol = np.empty(g.size, np.intp), np.empty(g.size), np.empty(g.size)
        out = (j, margin, tol) if ref is None else (j, margin, tol, ref)
        core.alloc_rows(*tables, np.ascontiguousarray(g, np.intp), lam, MARGIN_R, spread.dT_u, *out)
        spread.rows_of(g)
        return j, margin, tol

    rise = _Rise(core, tables, spread)
    J, lam = _bisect(J, live, step, spread.total, budget_t, rv.settle, rise)
    return (J if inv is None else J[inv]), lam


class _Rise:
    """_bisect's decade search (lambda only rises) on _allocate_rows' groups by the core's
    alloc_rise: start() costs every live group at lambda 0 by step, keeping each one's
    choice, second least cost and its choice's T and I (ref); at each decade then, a
    group whose choice's cost there is below that second least keeps its choice (each
    cost only grows with lambda: the proof is alloc_rise's, firmware/_core.c), so it is
    not costed again, and the others are (their choice, ref, margin and tol then kept).
    Each decade's T - T_orig are thus every group's at its choice there, as a step on
    every group writes them, and spent() the same bits; the margins and tols, which
    _bisect asks of its last decade only, are made there by alloc_rows for the groups
    alloc_rise kept (last()).  On the gyroid plate ~1 group in 4 is costed again a
    decade, instead of every one."""
    __slots__ = ("core", "tables", "spread", "live", "j", "ref", "margin", "tol", "kept", "n_kept")

    def __init__(self, core, tables, spread):
        self.core, self.tables, self.spread = core, tables, spread
        self.live = self.j = self.ref = self.margin = self.tol = self.kept = None
        self.n_kept = 0

    def start(self, step, live):
        """step(0.0, live)'s (choice, margin, tol), its choices and refs kept."""
        self.live = np.ascontiguousarray(live, np.intp)
        self.ref = np.empty((live.size, 3))
        got = step(0.0, live, self.ref)
        self.j = got[0].copy()
        self.margin, self.tol = np.empty(live.size), np.empty(live.size)
        self.kept = np.empty(live.size, np.intp)
        return got

    def __call__(self, lam):
        """The live groups' choices at lam (not below the last call's) and their T - T_orig
        (the margins and tols of those costed again)."""
        costed = self.core.alloc_rise(*self.tables, self.live, lam, self.j, self.ref, self.spread.dT_u,
                                      MARGIN_R, self.margin, self.tol, self.kept)
        self.n_kept = self.live.size - costed
        if costed:
            self.spread.refresh()

    def last(self, lam):
        """The last call's lam: every live group's (choice, margin, tol) there, those the
        call kept costed by alloc_rows (the same choice, and T - T_orig, written again).
        Ends the search: its arrays are given up."""
        kept = self.kept[:self.n_kept]
        if kept.size:
            j, margin, tol = np.empty(kept.size, np.intp), np.empty(kept.size), np.empty(kept.size)
            self.core.alloc_rows(*self.tables, self.live.take(kept), lam, MARGIN_R, self.spread.dT_u, j, margin, tol)
            self.margin[kept], self.tol[kept] = margin, tol
        got = self.j, self.margin, self.tol
        # (held no longer: the bisection then holds these, and its peak is the old one)
        self.j = self.ref = self.margin = self.tol = self.kept = None
        return got


class _RowSpread:
    """_allocate_rows' T - T_orig: dT_u, each group's (the core writes it), and dT, every
    row's in row order, as the row-by-row allocation held it (so np.sum gives its bits).
    rows_of(g) copies the groups g's values to their rows after a step on them: the
    first step's groups are every group with a candidate (and the others' are set then),
    each later one's a subset of the last one's (_bisect only narrows them; _break_ties'
    step, on a bracket's rows that hold the last step's, is more groups: those rows are
    found among all), so the rows
    to copy are found among the last step's, not among all (the rectilinear plate: ~6 k
    groups live, ~10 after 20 of its 88 steps; a gather of every row a step cost more
    than the groups saved).  inv None: each row its own group (dT is dT_u).

    total() is np.sum(dT) (spent()).  While the steps are on one array g of at most
    MEMO_GROUPS groups (_bisect's late steps: 3-4 groups for ~65 of 80 steps on either
    plate), only those groups' values change, so dT, and its sum, is a function of
    dT_u[g]: each sum is kept by those values' bits and a state met again is not summed
    again (its groups' choices at the bracket's ends recur: ~60 sums of every row a call)."""
    __slots__ = ("inv", "dT_u", "dT", "g_n", "rows", "inv_rows", "memo_g", "memo")

    def __init__(self, inv, n_groups):
        self.inv = inv
        self.dT_u = np.empty(n_groups)
        self.dT = self.dT_u if inv is None else np.empty(inv.size)
        self.g_n = -1                 # the last step's number of groups (-1: no step yet)
        self.rows = self.inv_rows = None
        self.memo_g = self.memo = None    # the steps' groups and {dT_u[g] bits: sum}, or None

    def refresh(self):
        """Every row's value again from its group's (after _Rise changed some groups')."""
        self.memo_g = self.memo = None
        if self.inv is not None:
            np.take(self.dT_u, self.inv, out=self.dT)

    def total(self):
        """np.sum(dT), as a float."""
        if self.memo is None:
            return float(np.sum(self.dT))
        key = self.dT_u.take(self.memo_g).tobytes()
        got = self.memo.get(key)
        if got is None:
            got = self.memo[key] = float(np.sum(self.dT))
        return got

    def _watch(self, g):
        """A step on the groups g (the only ones whose values it writes): the sums are kept
        while the steps are on this same array (a new one, or one too large: none kept)."""
        if g is not self.memo_g:
            self.memo_g, self.memo = (g, {}) if g.size <= MEMO_GROUPS else (None, None)

    def rows_of(self, g):
        self._watch(g)
        if self.inv is None:
            return
        if self.g_n < 0 or g.size > self.g_n:      # (more: _break_ties' rows, found among all)
            self.dT[:] = self.dT_u[self.inv]
            live = np.zeros(self.dT_u.size, bool)
            live[g] = True
            self.rows = np.flatnonzero(live[self.inv])
            self.inv_rows = self.inv[self.rows]
            self.g_n = g.size
            return
        if g.size != self.g_n:        # fewer groups: their rows among the last ones'
            keep = np.zeros(self.dT_u.size, bool)
            keep[g] = True
            keep = np.flatnonzero(keep.take(self.inv_rows))     # (its places once, then takes)
            self.rows, self.inv_rows = self.rows.take(keep), self.inv_rows.take(keep)
            self.g_n = g.size
        self.dT[self.rows] = self.dT_u.take(self.inv_rows)


MEMO_GROUPS = 64       # _RowSpread.total: sums kept while a step's groups are at most these

USE_CORE = True        # tests turn it off: allocate's choices by numpy (the reference)


def _alloc_core():
    """The compiled core's alloc_choices (firmware/_core.c), or None: not built, stale,
    GCODE_OPT_PURE_PYTHON, or USE_CORE off."""
    if not USE_CORE:
        return None
    from .firmware import simulate
    core = simulate._core
    return core if core is not None and hasattr(core, "alloc_choices") and hasattr(core, "alloc_rows") else None


LAMBDA_MAX = 1e31      # above any lambda allocate visits (its decade search stops at 1e30)


def _fixed(Tx, Ix, finite, rows, j1):
    """Of the rows with at most one finite cost (j1: its column, or 0), those whose cost
    stays finite for lambda <= LAMBDA_MAX (plain tables: every T finite and >= 0), and
    their j1: argmin's choice at every lambda allocate visits (the others' costs are inf;
    with none finite, all are inf and argmin's is the first)."""
    t, i = Tx[rows, j1], Ix[rows, j1]
    ok = ~finite[rows, j1] | ((np.abs(i) < 1e300) & (t * LAMBDA_MAX < 1e300))
    return rows[ok], j1[ok]


def _least_two(cost):
    """Of each column of cost (w, m), holding no NaN: the row of its least entry (the
    first if several), that entry, and the second least (the least of the others: the
    least again where two rows hold it).  Kept row by row, elementwise: a later row
    replaces the least only where it is strictly less (argmin's first)."""
    c1 = cost[0]
    jn = np.zeros(cost.shape[1], np.intp)
    c2 = np.full(cost.shape[1], np.inf)
    for q in range(1, cost.shape[0]):
        x = cost[q]
        lt = x < c1
        c2 = np.where(lt, c1, np.minimum(c2, x))
        c1 = np.where(lt, x, c1)
        jn = np.where(lt, q, jn)
    return jn, c1, c2


def _narrow_tables(Tx, Ix, finite):
    """(is_narrow per row, row -> narrow row, narrow column -> column, T, I) of the rows
    with at most NARROW_COLS finite entries, those first in column order (T and I
    column-major: (NARROW_COLS, narrow rows)); None when
    there are none or the tables are no wider (a stroke's T and I are its own row's)."""
    n, k = Ix.shape
    w = max(NARROW_COLS, 2)
    if k <= w:
        return None
    is_n = finite.sum(axis=1) <= w
    if not is_n.any():
        return None
    rid = np.flatnonzero(is_n)
    m = rid.size
    # a stable argsort of ~finite, row by row, kept to its first w places: column by
    # column, the finite entries (at most w a row), then the others while places are left
    f = finite[rid]
    col = np.empty((m, w), np.int16 if k < 2 ** 15 else np.intp)
    fill = np.zeros(m, np.intp)
    for c in range(k):
        r = np.flatnonzero(f[:, c])
        col[r, fill[r]] = c
        fill[r] += 1
    for c in range(k):
        r = np.flatnonzero(~f[:, c] & (fill < w))
        if r.size == 0 and fill.min() >= w:
            break
        col[r, fill[r]] = c
        fill[r] += 1
    # column-major (w, rows): allocate's thin() works on whole columns
    Tn = np.ascontiguousarray(Tx[rid[:, None], col].T)
    In = np.ascontiguousarray(Ix[rid[:, None], col].T)
    pos = np.full(n, -1)
    pos[is_n] = np.arange(m)
    return is_n, pos, col, Tn, In


def _merge(mask, a, b):
    """One array of mask's length: a where mask, b elsewhere."""
    out = np.empty(mask.size, np.result_type(a, b))
    out[mask], out[~mask] = a, b
    return out


ALLOCATE_ROWS = 4096    # rows of a cost matrix in allocate (~0.7 MB a matrix of 21 columns)
NARROW_ROWS = 1 << 15   # rows of a narrow cost block in allocate (2 MB a matrix of 8 columns)
MARGIN_R = 1e-9     # a choice whose cost is below the next one's by more than this (relative)
                    # is beyond the rounding of I + lambda T (~1e-16): it cannot flip


def plan_auto(p: PlanInput, budget_t: float, cands=None, groups=None, memo=None) -> Plan:
    """cands: candidates_auto(p), when the caller plans the same strokes twice.

    groups: index arrays (lines, arcs, curves...).  Each group gets the share of the
    budget its strokes take of the print time and spends it on itself, so one kind of
    stroke is never made faster and stiffer to pay for another.

    memo: a dict the caller keeps across calls on the same p and cands (the budget runs),
    neither they nor the groups' arrays changed in place between the calls: what does not
    depend on the budget is made once (_AllocMemo)."""
    n = len(p.T_orig)     # (p.L may be set aside: PlanInput.set_aside)
    if n == 0:
        return Plan(0)
    # (every field of the plan is set below: Plan(n)'s defaults, 1.4 MB of arrays on the
    # gyroid plate made only to be replaced, were held at the windowed command's peak)
    plan = Plan.__new__(Plan)
    if cands is None:
        cands = candidates_auto(p)
    if not isinstance(cands, Candidates):
        cands = Candidates.of_tables(*cands)
    # a stroke whose original figures are not finite takes no part in the allocation (a
    # NaN there would silence the budget for the whole file): it keeps its original
    fine = np.isfinite(p.T_orig) & np.isfinite(p.I_orig)
    # (each group as given, beside its strokes taking part: the memo knows a group by the former)
    given = [(g0, g0[fine[g0]]) for g0 in (groups or [np.arange(n)])]
    given = [(g0, g) for g0, g in given if len(g)]
    groups = [g for _, g in given]
    total_t = sum(float(p.T_orig[g].sum()) for g in groups)
    k = cands.shape[1]
    j = np.full(n, k, dtype=int)      # rows in no group keep their original
    pos = np.full(n, -1, np.intp)     # a chosen candidate's place in cands.vals, where known
    lam = []
    for g0, g in given:
        share = budget_t * float(p.T_orig[g].sum()) / total_t if total_t > 0 else 0.0
        # with the compiled core, on the feasible entries where Candidates holds them (no
        # table copied: the packed tables were ~10 MB at the rectilinear plate's planning peak)
        core = _alloc_core()
        rv = None
        if core is not None and len(g):
            rv = cands.rows_view(g, p.T_orig[g], p.I_orig[g]) if memo is None else _AllocMemo.of(memo, cands, g0, g, p).rv
        if rv is not None:
            jp, lam_g = _allocate_rows(cands.vals, rv, share, core)
            took = jp < rv.cnt                  # their entries: each row's jp-th, read below
            # j only marks which rows take a candidate (< k): their figures are read at pos
            # below, never by column (their dense columns, _RowsView.columns' running counts
            # over the rows' masks, were ~5 ms a budget run on the rectilinear plate)
            j[g] = np.where(took, 0, k)
            pos[g[took]] = rv.first[took] + jp[took]
            del rv, jp, took
            lam.append(lam_g)
            continue
        # the extended tables of the group only, made from the feasible entries: the dense
        # tables, their copies for the group and the extended ones were ~30 MB at once
        Tx, Ix, finite, settle = cands.allocation_tables(g, p.T_orig[g], p.I_orig[g])
        j[g], lam_g = _allocate(Tx, Ix, finite, p.T_orig[g], share, settle)
        del Tx, Ix, finite
        lam.append(lam_g)
    plan.lam = max(lam) if lam else 0.0
    use = j < k
    plan.retime = use
    plan.T, plan.beta, plan.I_law, plan.KE_law = _chosen_figures(cands, use, pos, j, p.T_orig, p.I_orig)
    none_ok = cands.cnt == 0            # (~mask.any(axis=1): no feasible candidate)
    plan.reason = _reasons(n, "original is better within the time budget",
                           (none_ok, "no law within limits"), (use, "retimed"))
    return plan


def _chosen_figures(cands, use, pos, j, T_orig, I_orig):
    """(T, beta, I_law, KE_law) of every stroke: a row of use its chosen entry's (at pos
    where the compiled allocation located it, else its j-th candidate: Candidates.at),
    the others their original's (T_orig, inf, I_orig, nan).  Each a copy of its defaults
    with the chosen rows put in by 1-D gathers (a (4, n) table filled through 2-D masks,
    then four np.where: ~16 M instructions a budget run on the rectilinear plate)."""
    n = use.size
    known = np.flatnonzero(use & (pos >= 0))
    pos_known = pos[known]
    rest = np.flatnonzero(use & (pos < 0))
    at_rest = cands.at(rest, j[rest])
    # (weights set aside: their two rows read back together)
    at_known = cands.vals[:, pos_known] if type(cands.vals) is _AsideVals else None
    out = []
    for f, default in enumerate((T_orig, np.inf, I_orig, np.nan)):
        x = np.array(np.broadcast_to(default, n), float)
        x[known] = cands.vals[f][pos_known] if at_known is None else at_known[f]
        x[rest] = at_rest[f]
        out.append(x)
    return out


class _AllocMemo:
    """What plan_auto makes of one group that does not depend on the budget, kept across
    the budget runs: its Candidates.rows_view, a pass over every candidate entry (~5 ms a
    run on the rectilinear plate).  Known by the objects it was made of (the group's array
    as the caller gave it, p, cands: held here, so no other object takes their ids), which
    plan_auto's memo contract keeps unchanged; their bytes kept as the key were 1.25 MB
    through the rectilinear plate's runs, and a digest of them cost more than the pass."""
    __slots__ = ("made_of", "rv")

    @classmethod
    def of(cls, memo, cands, g0, g, p):
        """The memo of the group given as g0 (g: its rows taking part), made anew for
        another group array, p or cands."""
        key = ("group", id(g0), id(p), id(cands))
        got = memo.get(key)
        if got is not None and got.made_of[0] is g0 and got.made_of[1] is p and got.made_of[2] is cands:
            return got
        self = cls()
        self.made_of = (g0, p, cands)
        self.rv = cands.rows_view(g, _rows_of(p.T_orig, g), _rows_of(p.I_orig, g))
        memo[key] = self
        return self


def plan_fixed_alpha(p: PlanInput, alpha: float) -> Plan:
    """beta fixed by alpha; T = shortest duration meeting the limits (bisection on T)."""
    n = len(p.L)
    plan = Plan(n)
    if n == 0:
        return plan
    beta = alpha * p.mass_r
    lo = np.maximum(p.L / np.maximum(p.v_cap, 1e-9), p.t_seg_min) * 0.999
    hi = np.maximum(p.T_orig * 1.5, lo * 1.01)   # beyond ~1.5x, fixed end speeds force a crawl or a reversal
    ok_hi = _feasible(line_law(p.L, hi, beta, p.v0, p.v1), p.v_cap, p.a_cap)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        ok = _feasible(line_law(p.L, mid, beta, p.v0, p.v1), p.v_cap, p.a_cap) & (mid >= p.t_seg_min)
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    law = line_law(p.L, hi, beta, p.v0, p.v1)
    KE, I = law.integrals()
    plan.retime = ok_hi
    plan.T = np.where(ok_hi, hi, p.T_orig)
    plan.beta = np.where(ok_hi, beta, np.inf)
    plan.I_law = np.where(ok_hi, I, p.I_orig)
    plan.KE_law = np.where(ok_hi, KE, np.nan)
    plan.reason = _reasons(len(ok_hi), "no law within limits", (ok_hi, "retimed"))
    return plan


def empty_table(pin: PlanInput, rows):
    """(rows, T, beta, I, KE) of shape (n, len(T_RATIOS)): every duration of T_RATIOS, no
    candidate yet (I inf, beta inf, KE nan) -- the kinds fill the columns they compute."""
    rows = np.asarray(rows, int)
    n, k_all = rows.size, len(T_RATIOS)
    T = pin.T_orig[rows, None] * T_RATIOS[None, :]
    return rows, T, np.full((n, k_all), np.inf), np.full((n, k_all), np.inf), np.full((n, k_all), np.nan)


def candidate_table(pin: PlanInput, rows, cols, solve_figures, gamma_min):
    """Candidates of curved strokes (arcs, curves), shared by arcs.py and curves.py.

    For strokes `rows` and the duration columns `cols` of T_RATIOS: beta starts at the
    largest the line law allows under the speed cap (capped at (T/gamma_min)^2: the
    curved laws need a finite weight), then solve_figures(flat_idx, T, beta) -> (int_v2,
    int_a2, ok) solves the true law; a candidate that breaks a limit is retried once at
    beta/4 (a flatter law).  Returns (T, beta, I, KE) of shape (n, len(T_RATIOS)), inf
    where nothing was computed or nothing met the limits."""
    rows = np.asarray(rows, int)
    n = rows.size
    if n == 0:
        return empty_table(pin, rows)[1:]
    # the columns' durations as empty_table's T has them (one product an entry: the same
    # bits); its four (n, len(T_RATIOS)) tables are made once the figures are, not held
    # beside the solve's temporaries
    Tc = pin.T_orig[rows, None] * T_RATIOS[None, cols]

    def flat(a):
        return np.broadcast_to(np.asarray(a)[:, None], Tc.shape).ravel()

    S, v0, v1, vc = (flat(a[rows]) for a in (pin.L, pin.v0, pin.v1, pin.v_cap))
    Tf = Tc.ravel()
    betaf = np.minimum(_largest_beta_under_speed_cap(S, Tf, v0, v1, vc), (Tf / gamma_min) ** 2)
    ok_v = ((v0 <= vc * (1 + SPEED_TOL_R)) & (v1 <= vc * (1 + SPEED_TOL_R))
            & (Tf >= flat(pin.t_seg_min[rows])) & (S / Tf <= vc))
    If = np.full(Tf.shape, np.inf)
    KEf = np.full(Tf.shape, np.nan)
    todo = np.flatnonzero(ok_v)
    for _ in range(2):
        if todo.size == 0:
            break
        iv, ia, ok = solve_figures(todo, Tf[todo], betaf[todo])
        If[todo[ok]] = ia[ok]
        KEf[todo[ok]] = iv[ok]
        todo = todo[~ok]
        betaf[todo] *= 0.25
    del todo, S, v0, v1, vc, ok_v
    _, T, beta, I, KE = empty_table(pin, rows)
    I[:, cols] = If.reshape(Tc.shape)
    KE[:, cols] = KEf.reshape(Tc.shape)
    beta[:, cols] = betaf.reshape(Tc.shape)
    return T, beta, I, KE


def take_shortest_feasible(plan: Plan, pin: PlanInput, rows, alpha, T, ok, int_v2, int_a2):
    """--alpha A on curved strokes: of the candidate durations T (n, k; ascending along
    k), keep each stroke's shortest one meeting the limits (ok), with its law's figures."""
    first = np.argmax(ok, axis=1)
    any_ok = ok.any(axis=1)
    r = np.arange(len(rows))
    plan.retime[rows] = any_ok
    plan.T[rows] = np.where(any_ok, T[r, first], pin.T_orig[rows])
    plan.beta[rows] = np.where(any_ok, alpha * pin.mass_r[rows], np.inf)
    plan.I_law[rows] = np.where(any_ok, int_a2[r, first], pin.I_orig[rows])
    plan.KE_law[rows] = np.where(any_ok, int_v2[r, first], np.nan)
    plan.reason[rows] = np.where(any_ok, "retimed", "no law within limits")
