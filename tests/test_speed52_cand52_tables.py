"""Session 52 (cand52): the candidates' memory, same bits.  Each new path against the code
it replaced (kept below verbatim as references, from 872f8f0):
- Candidates.of_pieces: the entries' columns taken from each piece as it is copied (no
  (n, k) mask of every row, no _entry_columns pass): every field (col, vals, first, cnt,
  t_pos, k) and the bad rows equal the old one's, on the pieces of real samples (own and
  shared pieces, windows through a PiecesMemo) and on pieces made up here (bad rows,
  rows no piece covers, shared rows);
- plan._shared_piece: the pieces copied into arrays made once (the list emptied), field
  for field the old concatenation;
- PiecesMemo.piece: the memo spent (nothing held) and the SharedPiece the old one;
- candidates_in_windows: the pieces let go while of_pieces copies them;
- curves._levels_later: the levels the curves' candidates give as a function (own_levels)
  equal the old closure's (_levels_of over the per-candidate arrays), and hold no array
  of the call's candidates but their own T, beta and rows."""
import gc
import os
import weakref

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import features as feat
from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import T_RATIOS, Candidates, SharedPiece
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE, K_LINE

S = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus")


# ---------------------------------------------------------------- references (872f8f0)
def ref_entry_columns(mask, first, cnt, m):
    k = mask.shape[1]
    col = np.zeros(m, np.int8 if k <= 127 else np.intp)
    for a in range(0, mask.shape[0], plan_mod.ENTRY_ROWS):
        cc = np.flatnonzero(mask[a:a + plan_mod.ENTRY_ROWS]) % k
        c = cnt[a:a + plan_mod.ENTRY_ROWS]
        col[np.repeat(first[a:a + plan_mod.ENTRY_ROWS] - (np.cumsum(c) - c), c) + np.arange(cc.size)] = cc
    return col


def ref_of_pieces(n, pieces, T_orig):
    """Candidates.of_pieces at 872f8f0 (its Candidates.__init__ inlined): (first, cnt, col,
    vals, t_pos, k, bad)."""
    k = len(T_RATIOS)
    mask = np.zeros((n, k), bool)
    t_pos = plan_mod._ratios_nonneg(T_orig)
    own = np.ones(n, bool)
    bad = []
    for pc in pieces:
        if type(pc) is SharedPiece:
            mask[pc.rows], t_pos[pc.rows] = pc.mask[pc.inv], pc.t_pos[pc.inv]
            own[pc.rows] = False
            bad.append(pc.rows[pc.bad[pc.inv]])
        else:
            sub, m, _, tp, b = pc
            mask[sub], t_pos[sub] = m, tp
            bad.append(sub[b])
    cnt = mask.sum(axis=1)
    own_cnt = np.where(own, cnt, 0)
    first = np.cumsum(own_cnt) - own_cnt
    end = int(own_cnt.sum())
    at = []
    for pc in pieces:
        if type(pc) is SharedPiece:
            cnt_u = pc.mask.sum(axis=1)
            first[pc.rows] = end + (np.cumsum(cnt_u) - cnt_u)[pc.inv]
            at.append(end)
            end += int(cnt_u.sum())
    cnt = np.ascontiguousarray(cnt, np.intp)
    first = np.ascontiguousarray(first, np.intp)
    vals = np.empty((4, end))
    col = ref_entry_columns(mask, first, cnt, end)
    for pc in pieces[::-1]:
        if type(pc) is SharedPiece:
            a = at.pop()
            vals[:, a:a + pc.vals.shape[1]] = pc.vals
        else:
            m = pc[1]
            c = m.sum(axis=1)
            pos = np.repeat(first[pc[0]] - (np.cumsum(c) - c), c) + np.arange(int(c.sum()))
            for dst, src in zip(vals, pc[2]):
                dst[pos] = src
    return first, cnt, col, vals, t_pos, k, (np.sort(np.concatenate(bad)) if bad else np.zeros(0, int))


def ref_shared_piece(rows, made, inv):
    return SharedPiece(rows, np.concatenate([pc[1] for pc in made]), np.concatenate([pc[2] for pc in made], axis=1),
                       np.concatenate([pc[3] for pc in made]), np.concatenate([pc[4] for pc in made]), inv)


def ref_levels_of(rows_k, k, L, v0, v1, keff_rows, idx, T, beta):
    """candidates_curve's _levels_of at 872f8f0 over its per-candidate arrays (each row's
    value k times)."""
    S, V0, V1 = (np.repeat(x, k) for x in (L, v0, v1))
    keff = keff_rows[np.repeat(np.arange(rows_k), k)]
    R = 1.0 / keff[idx]
    return circle.grid_levels_of(S[idx] / R, T, beta, V0[idx] / R, V1[idx] / R)


# ---------------------------------------------------------------- helpers
def _same_bits(a, b, what):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape, what
    assert a.tobytes() == b.tobytes(), what


def _assert_of_pieces(n, pieces, T_orig):
    want = ref_of_pieces(n, list(pieces), T_orig)
    got, bad = Candidates.of_pieces(n, list(pieces), T_orig)
    for name, w in zip(("first", "cnt", "col", "vals", "t_pos"), want[:5]):
        _same_bits(w, getattr(got, name), name)
    assert got.k == want[5] and got.T_orig is T_orig
    _same_bits(want[6], bad, "bad rows")
    return got


def _setup(name, folder=S):
    prof = load_profile("prusa-mk3s")
    path = os.path.join(folder, name)
    opts = Options(features=feat.default_selection(path)[0])
    strokes, _ = analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
    return prof, opts, strokes, pin, rows


def _sample_pieces(name, K):
    """The pieces candidates_in_windows gives of_pieces (K windows), and n, T_orig."""
    prof, opts, strokes, pin, rows = _setup(name)
    failed = sc._faults_of(pin.fault)
    got = []
    f = Candidates.of_pieces.__func__

    def keep(cls, n, pieces, T_orig):
        got.append((n, list(pieces), T_orig))
        return f(cls, n, pieces, T_orig)
    Candidates.of_pieces = classmethod(keep)
    try:
        sc.candidates_in_windows(strokes, pin, prof, opts, rows, failed, np.linspace(0, len(strokes), K + 1).astype(int))
    finally:
        Candidates.of_pieces = classmethod(f)
    return got[0]


# ---------------------------------------------------------------- of_pieces
@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode", "prusa_klipper.gcode",
                                  "cura_box.gcode"])
@pytest.mark.parametrize("K", [1, 8])
def test_of_pieces_as_before_samples(name, K):
    n, pieces, T_orig = _sample_pieces(name, K)
    if name == "prusa_mk3s_rectilinear.gcode":       # (its lines through the memo: a shared piece)
        assert any(type(pc) is SharedPiece for pc in pieces)
    _assert_of_pieces(n, pieces, T_orig)


def test_of_pieces_as_before_made_up():
    """Own pieces with bad rows and rows no piece covers, two shared pieces (one of rows
    some of which are bad), in any order."""
    rng = np.random.default_rng(52)
    k, n = len(T_RATIOS), 300
    T_orig = rng.uniform(0.01, 2.0, n)
    T_orig[7] = -1.0                     # (a t_pos False)
    perm = rng.permutation(n)
    own_rows, sh1, sh2 = np.sort(perm[:140]), perm[140:220], perm[220:290]     # (10 rows left out)

    def own(sub):
        m = rng.random((sub.size, k)) < 0.3
        b = rng.random(sub.size) < 0.1
        m[b] = False
        return sub, m, rng.normal(size=(4, int(m.sum()))), rng.random(sub.size) < 0.9, b

    def shared(rows, n_u):
        m = rng.random((n_u, k)) < 0.25
        b = rng.random(n_u) < 0.2
        m[b] = False
        inv = rng.integers(0, n_u, rows.size)
        inv[:n_u] = np.arange(n_u)                       # (each distinct row some row's)
        return SharedPiece(rows, m, rng.normal(size=(4, int(m.sum()))), rng.random(n_u) < 0.9, b, rng.permutation(inv))
    pieces = [own(own_rows[:50]), shared(sh1, 30), own(own_rows[50:]), shared(sh2, 12)]
    for order in (pieces, pieces[::-1], [pieces[1], pieces[0], pieces[3], pieces[2]]):
        got = _assert_of_pieces(n, order, T_orig)
        assert got.cnt[perm[290:]].sum() == 0
    _assert_of_pieces(n, [], T_orig)


def test_of_pieces_empties_the_list():
    """of_pieces lets each piece go once copied: the list emptied, the pieces' arrays freed."""
    n, pieces, T_orig = _sample_pieces("prusa_gyroid.gcode", 4)
    refs = [weakref.ref(pc[2].base if pc[2].base is not None else pc[2]) for pc in pieces
            if type(pc[2]) is np.ndarray]
    assert refs
    Candidates.of_pieces(n, pieces, T_orig)
    assert pieces == []
    gc.collect()
    assert all(r() is None for r in refs)


# ---------------------------------------------------------------- shared pieces, the memo
def _line_pin(name="prusa_mk3s_rectilinear.gcode"):
    prof, opts, strokes, pin, rows = _setup(name)
    r = np.array([i for i in rows[K_LINE] if not pin.fault[i]], int)
    return pin, r


@pytest.mark.parametrize("chunk", [64, 4096])
def test_shared_piece_as_before(chunk):
    pin, r = _line_pin()
    made = plan_mod.candidate_pieces(pin.take(r), r, pin.T_orig, chunk=chunk)
    assert len(made) >= 1
    inv = np.arange(r.size)[::-1].copy()
    want = ref_shared_piece(r, made, inv)
    got = plan_mod._shared_piece(r, list(made), inv)
    for f in SharedPiece._fields:
        _same_bits(getattr(want, f), getattr(got, f), f)
    lst = list(made)
    plan_mod._shared_piece(r, lst, inv)
    assert lst == []


def test_memo_spent_by_piece():
    """PiecesMemo.piece gives the old SharedPiece and holds nothing after (each call's new
    inputs made as they come: make_rows 0, its pieces all in memo.made before piece)."""
    pin, r = _line_pin()
    memo = plan_mod.PiecesMemo(make_rows=0)
    for w in np.array_split(r, 5):
        assert memo.add(plan_mod.candidate_pieces, pin.take(w), w, pin.T_orig)
    want = ref_shared_piece(np.concatenate(memo.rows), list(memo.made), np.concatenate(memo.inv))
    got = memo.piece()
    assert len(got) == 1
    for f in SharedPiece._fields:
        _same_bits(getattr(want, f), getattr(got[0], f), f)
    assert len(memo.index) == 0 and memo.rows == [] and memo.inv == [] and memo.made == []
    assert memo.piece() == []


# ---------------------------------------------------------------- the curves' levels asked later
def _curve_case(name="prusa_gyroid.gcode"):
    prof, opts, strokes, pin, rows = _setup(name)
    r = rows[K_CURVE]
    r = r[[not pin.fault[i] for i in r]]
    assert r.size > 10
    return prof, strokes, pin, r


def test_levels_later_as_before():
    """_levels_later(idx // k, ...) against _levels_of over the per-candidate arrays, on a
    sample's curves (their κ_eff, lengths, end speeds) at random candidates."""
    prof, strokes, pin, r = _curve_case()
    k = len(curves.CURVE_COLS)
    keff_r = np.array([curves.geom(strokes[i], prof).kappa_eff for i in r.tolist()])
    L, v0, v1 = pin.L[r], pin.v0[r], pin.v1[r]
    rng = np.random.default_rng(5)
    checked = 0
    for _ in range(20):
        idx = np.sort(rng.choice(r.size * k, size=int(rng.integers(1, r.size * k)), replace=False))
        T = pin.T_orig[r][idx // k] * T_RATIOS[curves.CURVE_COLS][idx % k]
        beta = rng.uniform(1e-6, 1e-2, idx.size) * T ** 2
        want = ref_levels_of(r.size, k, L, v0, v1, keff_r, idx, T, beta)
        got = curves._levels_later(idx // k, T, beta, L, v0, v1, keff_r)()
        assert got == want and want is not None
        checked += 1
    assert checked == 20


def test_own_levels_functions_hold_little():
    """The functions candidates_curve gives own_levels (a pass that made no figures) hold
    no array of size rows x k but their candidates' own: T, beta and their rows."""
    prof, strokes, pin, r = _curve_case()
    owns = []
    curves.candidates_curve(pin, r, strokes, prof, None, owns, True)
    later = [lv for lv, _ in owns if callable(lv)]
    assert later, "no pass without figures on this sample: nothing checked"
    k = len(curves.CURVE_COLS)

    def arrays(f, seen):
        for c in f.__closure__ or ():
            x = c.cell_contents
            if isinstance(x, np.ndarray):
                yield x
            elif callable(x) and getattr(x, "__closure__", None) and id(x) not in seen:
                seen.add(id(x))
                yield from arrays(x, seen)
        for x in f.__defaults__ or ():
            if callable(x) and id(x) not in seen:
                seen.add(id(x))
                yield from arrays(x, seen)
    for f in later:
        held = list(arrays(f, set()))
        assert held and not any(a.size == r.size * k for a in held)
        assert isinstance(f(), int)


# ---------------------------------------------------------------- the windows' rows
def test_window_rows_as_before():
    """_WindowRows (views, made when asked) against the windows' copies as they were made:
    a window, and windows together."""
    rng = np.random.default_rng(3)
    n = 1000
    codes = rng.integers(0, 4, n)
    rows = {k: np.flatnonzero(codes == k) for k in range(4)}
    rows[4] = np.zeros(0, np.intp)
    shuffled = {k: rng.permutation(r) for k, r in rows.items()}
    bounds = [0, 1, 17, 500, 501, 999, 1000]
    for rr, ordered in ((rows, True), (shuffled, False)):
        window_rows = sc._WindowRows(rr, np.array(bounds), ordered)
        for a, e in [(j, j + 1) for j in range(len(bounds) - 1)] + [(0, 3), (2, 6), (0, 6), (3, 3)]:
            lo, hi = bounds[a], bounds[e]
            want = {k: r[(r >= lo) & (r < hi)] for k, r in rr.items()}       # (872f8f0's)
            got = window_rows(a, e)
            assert list(got) == list(want)
            for k in want:
                _same_bits(want[k], got[k], k)


def test_windows_let_pieces_go():
    """candidates_in_windows hands of_pieces the one list of its pieces: each is freed once
    copied, before of_pieces returns (872f8f0 held them all to the end: a joined copy of
    the list, and each window's curve pieces)."""
    prof, opts, strokes, pin, rows = _setup("prusa_gyroid.gcode")
    failed = sc._faults_of(pin.fault)
    f = Candidates.of_pieces.__func__
    seen = []

    def watch(cls, n, pieces, T_orig):
        refs = [weakref.ref(pc[2]) for pc in pieces if pc[2].size]      # (an empty one may be shared)
        kinds = {type(pc) for pc in pieces}
        out = f(cls, n, pieces, T_orig)
        gc.collect()
        seen.append((len(refs), sum(r() is not None for r in refs), kinds))
        return out
    Candidates.of_pieces = classmethod(watch)
    try:
        sc.candidates_in_windows(strokes, pin, prof, opts, rows, failed, np.linspace(0, len(strokes), 5).astype(int))
    finally:
        Candidates.of_pieces = classmethod(f)
    (n_pieces, alive, kinds), = seen
    assert n_pieces > 4 and SharedPiece in kinds
    assert alive == 0


# ---------------------------------------------------------------- the lines' inputs once
def ref_pieces_once(make, p, rows, T_orig):
    """plan.pieces_once at 872f8f0."""
    rows = np.asarray(rows)
    same = plan_mod._same_inputs(p)
    if same is None:
        return make(p, rows, T_orig)
    first, inv = same
    made = make(p.take(first), rows[first], T_orig)
    if not plan_mod._made_in_order(made, rows[first]):
        return make(p, rows, T_orig)
    return [ref_shared_piece(rows, made, inv)]


def _assert_pieces_same(want, got):
    assert [type(pc) for pc in want] == [type(pc) for pc in got]
    for a, b in zip(want, got):
        for j, (x, y) in enumerate(zip(a, b)):
            _same_bits(x, y, j)


@pytest.mark.parametrize("name", ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid.gcode"])
def test_pieces_once_of_as_before(name):
    """pieces_once_of(make, pin, rows) and pieces_once against the old pieces_once of
    pin.take(rows): the same pieces (shared where the inputs repeat, else each row's), and
    the rows' copy of the inputs not alive while the distinct rows' pieces are made."""
    pin, r = _line_pin(name)
    rows = np.repeat(r, 3)                  # (inputs that repeat: a shared piece on any sample)
    calls = []

    def make(p, rr, t):
        gc.collect()
        calls.append((len(p.L), sum(1 for o in gc.get_objects() if type(o) is plan_mod.PlanInput
                                    and len(o.L) == rows.size)))
        return plan_mod.candidate_pieces(p, rr, t, chunk=256)
    want = ref_pieces_once(lambda p, rr, t: plan_mod.candidate_pieces(p, rr, t, chunk=256), pin.take(rows), rows,
                           pin.T_orig)
    assert type(want[0]) is SharedPiece
    _assert_pieces_same(want, plan_mod.pieces_once_of(make, pin, rows))
    (n_made, alive), = calls                # (the distinct rows only; no copy of all the rows alive)
    assert n_made <= r.size and alive == 0
    _assert_pieces_same(want, plan_mod.pieces_once(lambda p, rr, t: plan_mod.candidate_pieces(p, rr, t, chunk=256),
                                                   pin.take(rows), rows, pin.T_orig))
    # where the inputs do not repeat enough: every row's own, as before
    few = r[:40]
    _assert_pieces_same(ref_pieces_once(plan_mod.candidate_pieces, pin.take(few), few, pin.T_orig),
                        plan_mod.pieces_once_of(plan_mod.candidate_pieces, pin, few))
