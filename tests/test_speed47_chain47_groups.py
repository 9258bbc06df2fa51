"""Session 47 (chain47), the chains' candidates, same bits as the code replaced (kept here):
  - chains._count_groups: _table_rows' groups of chains by segment count made in one pass;
    the same index arrays, in the same order, as the per-count loop;
  - chains._flat_chains with the geometries handed in and the floats by objfields: the
    same arrays, bit for bit, as before (and by its fallback)."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.distinct import distinct


def _groups_ref(nseg, has, rows):
    """_table_rows' grouping as of 882d7e9 (verbatim)."""
    groups = []
    for q in distinct(nseg[has]).tolist():
        J = np.flatnonzero(has & (nseg == q))
        cut = np.cumsum(rows[J]) // chains.FINISH_ROWS          # nondecreasing
        groups += np.split(J, np.flatnonzero(np.diff(cut)) + 1)
    return groups


def _same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.dtype == y.dtype and np.array_equal(x, y)


@pytest.mark.parametrize("seed", range(40))
@pytest.mark.parametrize("sort", [True, False])
def test_count_groups_as_the_loop(seed, sort):
    rng = np.random.default_rng(seed)
    m = int(rng.integers(0, 400))
    nseg = rng.integers(2, 2 + int(rng.integers(1, 30)), m).astype(np.int64)
    if sort:
        nseg.sort()
    use = rng.random((m, 5)) < rng.random()
    has = use.any(axis=1)
    rows = use.sum(axis=1)
    if seed % 3 == 0:        # many rows a chain: groups cut inside a count
        rows = rows * int(rng.integers(100, 1500))
    _same(chains._count_groups(nseg, has, rows), _groups_ref(nseg, has, rows))


def test_count_groups_cuts_and_empty():
    nseg = np.array([3, 3, 3, 3, 5, 5, 4, 4], np.int64)
    rows = np.array([1000, 1000, 100, 2000, 5, 3000, 2048, 1], np.int64)
    has = np.ones(8, bool)
    has[1] = False
    _same(chains._count_groups(nseg, has, rows), _groups_ref(nseg, has, rows))
    assert chains._count_groups(nseg, np.zeros(8, bool), rows) == []


# ---------------------------------------------------------------- _flat_chains (session 47)
from gcode_opt import curves, objfields            # noqa: E402

from chain_cases import fresh_chains               # noqa: E402


def _flat_chains_ref(sts, profile):
    """chains._flat_chains as of 882d7e9 (verbatim)."""
    gs = [curves.geom(st, profile) for st in sts]
    caps = chains._kept_caps(sts, gs, profile)
    cv = chains._join_caps(caps)
    return chains._Flat.of_arrays(chains._inner_s(gs), cv if cv.flags.writeable else cv.copy(),
                                  chains._caps_sizes(caps),
                                  np.array([st.length_d for st in sts], float), np.zeros(len(sts)),
                                  np.ones(len(sts)),
                                  np.array([st.v0 for st in sts], float), np.array([st.v1 for st in sts], float))


def _same_flat(a, b):
    for f in ("sv", "cv", "nv", "voff", "S", "T", "beta", "v0", "v1", "ch"):
        x, y = getattr(a, f), getattr(b, f)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), f
    assert a.monotone == b.monotone


@pytest.mark.parametrize("path,prof_name", [("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
                                            ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24")])
def test_flat_chains_as_before(path, prof_name, monkeypatch):
    """_flat_chains (its geometries given or made, the floats by objfields or by its fallback)
    gives the arrays the code it replaced gave, bit for bit."""
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    sts = [strokes[i] for i in rows[:400].tolist()]
    want = _flat_chains_ref(sts, prof)
    _same_flat(chains._flat_chains(sts, prof), want)
    _same_flat(chains._flat_chains(sts, prof, [curves.geom(st, prof) for st in sts]), want)
    monkeypatch.setattr(objfields, "floats", lambda objs, names: None)       # (the fallback)
    _same_flat(chains._flat_chains(sts, prof), want)
