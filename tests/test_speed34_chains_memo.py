"""Issue 8, session 34 (the chains' memos held compactly through the plan): the candidate
table keeps one _KeptLaws per finishing batch, shared by its chains (a memo row's number
is its batch row), not one a chain; the kept binding masks are bits (_PackedMask) that
give back the masks' own bools, the rows' T and beta their cells' places in _figures'
tables (_Cells), the rows' pieces' durations spans of one array a chunk (_LawCols).
The plans made from the shared kept laws are those made from a chain's own
(tests/test_speed30_chains_laws.py: the rows made again are the table's knots; the
48-case set: the same bytes)."""
import numpy as np
import pytest

from chain_cases import fresh_chains
from gcode_opt import chains

SAMPLE = "sample_gcode/prusa_gyroid_fullspeed.gcode"


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 23])
def test_packed_mask_gives_back_the_masks_rows(n):
    rng = np.random.default_rng(n)
    mask = rng.random((37, n)) < 0.4
    packed = chains._PackedMask(mask)
    assert packed.shape == mask.shape
    assert packed.bits.nbytes == 37 * ((n + 7) // 8)
    for rows in ([3, 0, 3, 36], np.array([5, 1, 2], np.int64), np.arange(37), slice(4, 20)):
        got = packed[rows]
        assert got.dtype == bool and np.array_equal(got, mask[rows])
    one = packed[11]
    assert one.dtype == bool and np.array_equal(one, mask[11])


def _fresh_table(prof_name):
    strokes, pin, rows, prof, rules = fresh_chains(SAMPLE, prof_name)
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    return strokes, rows, prof, rules


def test_cells_are_the_tables_doubles():
    rng = np.random.default_rng(3)
    table = rng.random((50, 5))
    table[7, 2] = -0.0
    view = table[10:40]                     # (a chunk's rows of the table, as _Finisher has them)
    row = rng.integers(0, 30, 200)
    col = rng.integers(0, 5, 200)
    cells = chains._Cells(view, row, col)
    want = view[row, col]
    assert cells.shape == want.shape and cells.ndim == 1 and cells.at.dtype == np.int32
    for q in ([5, 0, 5], np.arange(200), np.array([199, 3], np.int64)):
        assert cells[q].tobytes() == want[q].tobytes()
    assert cells[17] == want[17] and chains._Cells(table, [7], [2])[[0]].tobytes() == np.array([-0.0]).tobytes()


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])
def test_one_kept_laws_a_batch_its_rows_the_batch_rows(prof_name):
    strokes, rows, prof, rules = _fresh_table(prof_name)
    kepts, memo_rows = {}, 0
    for i in rows.tolist():
        for t, TL, b, r, kept in strokes[i].chain_T.rows():
            assert type(kept) is chains._KeptLaws and kept.lo == 0 and kept.st is None
            kepts[id(kept)] = kept
            base = kept.base
            q = int(r)
            # the row r of the batch is this chain's candidate (T, beta, predicted time)
            assert q == r and 0 <= q < kept.k == base[0].shape[0]
            assert base[3][q] == TL and base[4][q] == b and base[5][q] == t
            memo_rows += 1
    # one kept laws (and one base) a finishing batch, not one a chain
    assert len({id(k.base) for k in kepts.values()}) == len(kepts)
    assert memo_rows > 3 * rows.size and 3 * len(kepts) < rows.size


def test_rows_share_their_chunks_pieces(prof_name="prusa-mk3s"):
    """The kept rows' pieces' durations are spans of one array a chunk of chains, shared by
    its batches' rows (a chain and its first equal: the same span), not copied row by row."""
    strokes, rows, prof, rules = _fresh_table(prof_name)
    bases = {}
    for i in rows.tolist():
        for *_, kept in strokes[i].chain_T.rows():
            bases[id(kept.base)] = kept.base
    pieces = {id(b[1]): b[1].size for b in bases.values()}
    spans = np.concatenate([b[2] for b in bases.values()])
    assert spans.dtype == np.int32 and (spans[:, 1] >= 1).all()
    assert len(pieces) < len(bases)                          # one pieces array, several batches
    assert all(((b[2][:, 0] >= 0) & (b[2][:, 0] + b[2][:, 1] <= b[1].size)).all() for b in bases.values())
    assert sum(pieces.values()) < int(spans[:, 1].sum())    # rows of equal chains share their pieces


def test_plan_of_a_shared_kept_row_is_the_tables(prof_name="prusa-mk3s"):
    """plan_chain_segments of each chain's candidates from the shared kept laws: each plan's
    predicted time is its row's (the table's), and the memos' rows are dropped after."""
    strokes, rows, prof, rules = _fresh_table(prof_name)
    sts, T, B, want = [], [], [], []
    for i in rows.tolist():
        got = strokes[i].chain_T.rows()
        if got:
            t, TL, b, _, _ = got[len(got) // 2]
            sts.append(strokes[i])
            T.append(t)
            B.append(b)
            want.append(t)
    plans = chains.plan_chain_segments(sts, np.array(T), np.array(B), rules, prof)
    assert len(plans) == len(sts) > 100
    assert all(p.time_t == w for p, w in zip(plans, want))
    assert all(type(st.chain_T.kept) is not chains._KeptLaws for st in sts)
