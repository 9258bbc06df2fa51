"""stroke_store / stored_strokes (issue 8, inputs56): the store's reads and the side tables'
objects put back as a window is made.

- the records of rows that are not adjacent (the rewrite's held rows: most of a window's)
  read with their small gaps in one read, not a read a run, and the far ones apart (the
  read buffer stays at most twice the records'); the strokes the same as the originals;
- take / load's `over`: the objects given put in their field where not None, the record's
  value elsewhere, compiled and pure alike;
- StoredStrokes gives its kept objects back through the load: no empty ChainMemo made for a
  row whose memo is kept."""
import numpy as np
import pytest

from gcode_opt import stroke_store as ss, stored_strokes
from gcode_opt.chains import ChainMemo
from gcode_opt.stored_strokes import StoredStrokes

from test_speed50_store50_roundtrip import PATHS, ROOT, _strokes, check_same

GYROID = str(ROOT / "sample_gcode/prusa_gyroid.gcode")


@pytest.fixture(scope="module")
def planned():
    sts, plan = _strokes(GYROID)
    plan()                          # (chains marked: ChainMemo records)
    assert len(sts) > 600 and any(s.chain_T is not None for s in sts)
    return sts


def _reads(monkeypatch):
    seen = []
    real = ss._TempFile.read_into

    def counted(self, mv, pos):
        seen.append((pos, len(mv)))
        return real(self, mv, pos)
    monkeypatch.setattr(ss._TempFile, "read_into", counted)
    return seen


@pytest.mark.parametrize("pure", PATHS)
def test_rows_with_small_gaps_are_one_read(monkeypatch, planned, pure):
    """Three rows of four (runs of 3, a record's gap each): one read, not ~150."""
    sts = planned[:600]
    rows = np.array([r for r in range(len(sts)) if r % 4 != 1], np.int64)
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts)
        seen = _reads(monkeypatch)
        back = store.take(rows)
    assert len(seen) == 1, len(seen)
    check_same([sts[r] for r in rows.tolist()], back)


@pytest.mark.parametrize("pure", PATHS)
def test_far_rows_are_read_apart(monkeypatch, planned, pure):
    """Rows far apart (the gap larger than the records asked): a read each, the buffer not
    the whole span; a row asked twice or before the one asked last: a read of its own."""
    sts = planned
    far = [0, 1, len(sts) - 2, len(sts) - 1]
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts)
        seen = _reads(monkeypatch)
        back = store.take(np.array(far, np.int64))
        assert len(seen) == 2 and sum(n for _, n in seen) == int(store._len[far].sum()), seen
        check_same([sts[r] for r in far], back)
        del seen[:]
        odd = [5, 6, 6, 3, 4]
        check_same([sts[r] for r in odd], store.take(np.array(odd, np.int64)))
        assert len(seen) == 3, seen


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("in_memory", [False, True])
def test_over_puts_the_objects_given(planned, pure, in_memory):
    sts = planned
    chains = [r for r, s in enumerate(sts) if s.chain_T is not None]
    assert len(chains) > 3
    marks = {r: object() for r in chains[::2]}
    marks[chains[1] + 1 if chains[1] + 1 not in chains else 0] = object()    # (a row stored None)
    with ss.StrokeStore(pure=pure, in_memory=in_memory) as store:
        store.append(sts)
        over = [marks.get(r) for r in range(len(sts))]
        for got in (store.load(0, len(sts), {"chain_T": over}),
                    store.take(np.arange(len(sts), dtype=np.int64), {"chain_T": over})):
            for r, st in enumerate(got):
                if r in marks:
                    assert st.chain_T is marks[r], r
                elif r in chains:
                    assert type(st.chain_T) is ChainMemo and st.chain_T is not sts[r].chain_T, r
                else:
                    assert st.chain_T is None, r
            rest = list(got)
            for r in marks:                              # every other field the record's
                rest[r].chain_T = None if sts[r].chain_T is None else ChainMemo()
            check_same(sts, rest)
        with pytest.raises(ValueError):
            store.load(0, 10, {"chain_T": [None] * 9})


def test_over_batches_take_their_rows(planned, monkeypatch):
    """The objects of each decode batch are the rows' of that batch (BATCH 16 here)."""
    monkeypatch.setattr(ss, "BATCH", 16)
    sts = planned[:100]
    marks = [object() for _ in sts]
    with ss.StrokeStore() as store:
        store.append(sts)
        got = store.take(np.arange(3, 90, dtype=np.int64), {"chain_T": marks[3:90]})
    assert all(st.chain_T is m for st, m in zip(got, marks[3:90]))


class _Counted(ChainMemo):
    made = 0

    def __init__(self):
        type(self).made += 1
        super().__init__()


@pytest.mark.parametrize("pure", PATHS)
def test_kept_memos_not_made_again(planned, pure):
    """A window loaded again gets its chains' kept memos from the load itself: no new empty
    memo is made for them (nor for the rest: rows without a chain hold None)."""
    sts = planned
    _Counted.made = 0
    with ss.StrokeStore(in_memory=True, pure=pure) as store:
        store.append(sts)
        codec = store._codec
        if pure:
            codec.Memo = _Counted
        else:
            codec._kit = codec._kit[:5] + (_Counted,)
        s = StoredStrokes(store, 64, 1, keep=("chain_T",))
        n_chains = sum(st.chain_T is not None for st in sts)
        mine = [st.chain_T for st in s]             # first pass: the store's empty memos
        first = _Counted.made
        assert first >= n_chains
        s.let_go()
        again = [st.chain_T for st in s]
        assert _Counted.made == first               # (none made the second time)
        assert all(a is b for a, b in zip(mine, again))
        assert sum(m is not None for m in again) == n_chains
    assert stored_strokes.HELD >= 1


class _Plain:
    """A memo class as ChainMemo is (object's, __slots__, constants set by __init__)."""
    __slots__ = ("a", "b", "c", "d")
    made = 0

    def __init__(self):
        type(self).made += 1
        self.a, self.b, self.c = None, -1, 0.5


class _Mutable(_Plain.__base__):
    """A memo whose __init__ makes a new object: called for each memo."""
    __slots__ = ("rows",)
    made = 0

    def __init__(self):
        type(self).made += 1
        self.rows = []


@pytest.mark.parametrize("pure", PATHS)
def test_decoded_memos_are_new_empty_ones(planned, pure):
    """Every ChainMemo decoded: a new object, each slot as ChainMemo() sets it."""
    with ss.StrokeStore(pure=pure) as store:
        store.append(planned)
        got = [st.chain_T for st in store.load(0, len(store)) if st.chain_T is not None]
    want = ChainMemo()
    assert len(got) > 10 and len({id(m) for m in got}) == len(got)
    for m in got:
        assert type(m) is ChainMemo
        for nm in ChainMemo.__slots__:
            assert getattr(m, nm) is getattr(want, nm) or getattr(m, nm) == getattr(want, nm), nm
        m.figs = object()                       # (a memo's own slots: the others' unchanged)
    assert all(getattr(m, "figs") is not None for m in got)


@pytest.mark.parametrize("cls", [_Plain, _Mutable])
def test_memo_class_called_once_where_copies_are_the_same(planned, cls):
    """The compiled decode calls a plain memo class once and copies its constants; one whose
    __init__ makes an object (a list) is called for every memo, each its own list."""
    if not ss.StrokeStore()._codec.__class__.__name__ == "_CCodec":
        pytest.skip("the compiled decode")
    with ss.StrokeStore() as store:
        store.append(planned)
        store._codec._kit = store._codec._kit[:5] + (cls,)
        cls.made = 0
        got = [st.chain_T for st in store.load(0, len(store)) if st.chain_T is not None]
    assert len(got) > 10 and all(type(m) is cls for m in got) and len({id(m) for m in got}) == len(got)
    if cls is _Plain:
        assert cls.made <= 1
        assert all((m.a, m.b, m.c) == (None, -1, 0.5) and not hasattr(m, "d") for m in got)
    else:
        assert cls.made in (len(got), len(got) + 1)      # (+ the one that showed its list)
        assert len({id(m.rows) for m in got}) == len(got)
