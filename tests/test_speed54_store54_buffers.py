"""stroke_store.StrokeStore (issue 8, store54): the encode and read buffers are a call's
own: between calls the store holds its records' offsets and lengths (and the interned
objects), not a buffer the size of a batch of records -- the windowed pipeline's chain
solves read no record, and encoding ends with the plan inputs.  Compiled and pure codec."""
import tracemalloc

import numpy as np
import pytest

from gcode_opt import stroke_store
from gcode_opt.stroke_store import StrokeStore

from test_speed51_lazy51_spill import _fields
from test_speed51_lazy51_stored import _strokes


def _held_b(fn):
    """bytes stroke_store.py allocated in fn() and still holds after it"""
    tracemalloc.start()
    try:
        fn()
        snap = tracemalloc.take_snapshot().filter_traces([tracemalloc.Filter(True, stroke_store.__file__)])
    finally:
        tracemalloc.stop()
    return sum(t.size for t in snap.traces)


@pytest.mark.parametrize("pure", [False, True])
def test_no_buffer_held_between_calls(pure):
    ref = _strokes("prusa_gyroid.gcode")
    n = len(ref)
    with StrokeStore(pure=pure) as store:
        rows = np.arange(n, dtype=np.int64)
        store.append(ref[:5])                      # (the offsets' arrays grown: not counted below)
        store._room(n)

        def spill():
            store.append(ref[5:])
        assert _held_b(spill) < 4096                # (a 1024-record batch's buffer: ~0.3 MB)
        records_b = store.nbytes
        assert _held_b(lambda: store.take(rows)) < 4096        # (the strokes let go)
        got = store.take(rows)
        assert [_fields(a) for a in got] == [_fields(b) for b in ref]
        assert _held_b(lambda: store.rewrite(rows[:700], got[:700])) < 4096
        assert store.nbytes == records_b           # (the same lengths: rewritten in place)
        assert [_fields(a) for a in store.load(0, n)] == [_fields(b) for b in ref]
        col = store.column("v_feed")
        assert col.tolist() == [st.v_feed for st in ref]
