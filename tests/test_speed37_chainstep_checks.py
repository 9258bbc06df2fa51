"""Issue 8 (s37, chainstep): the chain core's input checks as loops without an early exit
(all_in_range, all_finite, all_finite_pos: vectorized) and window_sums with its windows
side by side (win_sums), the same answers as the loops they replace.

- window_sums: each window's sum added left to right from 0.0 (the old loop, here in
  Python: the same additions in the same order), bit for bit, on values whose sums depend
  on that order, over window counts across the block size;
- the index checks of active_step, tod_at, tod_prep, fixed_knots and vert_prep (a vertex,
  piece or knot out of range: ValueError) and chain_finish's finite checks (vk, tk; the
  tent's feeds finite and > 0: False, the numpy code runs), on their real calls while a
  head of prusa_gyroid.gcode is processed, an entry made bad at its first, a middle and
  its last place; the calls as they were still pass."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.detect import auto_profile
from gcode_opt.laws import chain as lc
from gcode_opt.pipeline import Options, process

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
CORE = lc.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "take_blocks"), reason="no (new) chain core")


def _old_window_sums(x, nb):
    out = []
    for i in range(x.size - nb + 1):
        acc = 0.0
        for j in range(nb):
            acc = acc + float(x[i + j]) * 1.0
        out.append(acc)
    return np.array(out)


@needs_core
@pytest.mark.parametrize("nb", [1, 2, 3, 7, 16, 29])
@pytest.mark.parametrize("n", [1, 40, 511, 512, 513, 1300])
def test_window_sums_are_the_left_to_right_sums(nb, n):
    rng = np.random.default_rng(nb * 10_000 + n)
    size = n + nb - 1                                   # n windows
    x = rng.lognormal(0.0, 6.0, size) * rng.choice([-1.0, 1.0], size)      # sums depend on the order
    x[rng.integers(0, size, 3)] = [0.0, -0.0, 1e300]
    out = np.empty(n)
    CORE.window_sums(x, nb, out)
    assert out.tobytes() == _old_window_sums(x, nb).tobytes()


@needs_core
def test_window_sums_refuses_out_over_x():
    x = np.arange(20.0)
    with pytest.raises(ValueError):
        CORE.window_sums(x, 3, x[:18])
    with pytest.raises(ValueError):
        CORE.window_sums(x, 3, np.empty(17))


# name -> [(array's place in the args, the place of the array whose size bounds it)]
INDEXES = {"active_step": [(0, 4)], "tod_at": [(8, 0)], "tod_prep": [(8, 0)], "fixed_knots": [(3, 0)],
           "vert_prep": [(0, 4), (2, 6)], "tod_at_into": [(8, 0), (10, 11)]}
KEEP = 3          # calls kept of each


def _copy(a):
    """The args, their arrays copied (and the arrays of a list: active_step's hist grows)."""
    return [x.copy() if isinstance(x, np.ndarray) else [y.copy() for y in x] if isinstance(x, list) else x
            for x in a]


@pytest.fixture(scope="module")
def calls(tmp_path_factory):
    """The first calls of each checked function while a head of prusa_gyroid.gcode is
    processed (args copied as they came in), and what chain_finish returned."""
    got = {k: [] for k in list(INDEXES) + ["chain_finish"] if k not in ("tod_prep", "tod_at")}

    class Spy:
        def __getattr__(self, name):
            fn = getattr(CORE, name)
            if name not in got:
                return fn

            def rec(*a):
                a0 = _copy(a)
                out = fn(*a)
                if len(got[name]) < KEEP or (name == "chain_finish" and a[0] == 0 and out
                                             and not any(c[0][0] == 0 and c[1] for c in got[name])):
                    got[name].append((a0, out))
                return out
            return rec
    src = SAMPLES / "prusa_gyroid.gcode"
    d = tmp_path_factory.mktemp("chainstep")
    head = d / "head.gcode"
    with open(src) as fh:
        head.write_text("".join(fh.readlines()[:6000]))
    prof = auto_profile(str(src)).profile
    save = lc.CORE_MOD
    lc.CORE_MOD = Spy()
    try:
        process(str(head), str(d / "out.gcode"), prof, Options())
    finally:
        lc.CORE_MOD = save
    # tod_at (not called there: tod_at_into took its place, session 41) on tod_at_into's laws and
    # distances, with tod_at's own out, vout and act
    got["tod_at"] = [(list(a[:10]) + [np.empty(a[8].size), np.empty(a[8].size), np.empty(a[8].size, np.int64)]
                      + list(a[14:]), None) for a, _ in got["tod_at_into"]]
    # tod_prep (not called there: tod_at took its place) on tod_at's laws and distances
    got["tod_prep"] = [(list(a[:10]) + [np.empty(a[8].size) for _ in range(14)] + [np.empty(a[8].size, np.int64)],
                        None) for a, _ in got["tod_at"]]
    for k, v in got.items():
        assert v, k
    return got


@needs_core
@pytest.mark.parametrize("name", sorted(INDEXES))
def test_an_index_out_of_range_is_refused(calls, name):
    fn = getattr(CORE, name)
    for args, _ in calls[name]:
        fn(*_copy(args))                                   # as it came: no error
        for ia, ib in INDEXES[name]:
            n, hi = args[ia].size, args[ib].size
            assert n > 0
            for place in sorted({0, n // 2, n - 1}):
                for bad in (-1, hi, hi + 5, -(2 ** 62)):
                    a = _copy(args)
                    a[ia][place] = bad
                    with pytest.raises(ValueError):
                        fn(*a)
                if name != "active_step":      # (there a moved vertex changes the binding count it checks)
                    a = _copy(args)
                    a[ia][place] = hi - 1                  # the last one in range: no error
                    fn(*a)


@needs_core
def test_chain_finish_declines_what_is_not_finite(calls):
    jerk = [c for c in calls["chain_finish"] if c[0][0] == 0 and c[1]]
    assert jerk                                        # a classic-jerk batch the core took
    for args, out in calls["chain_finish"]:
        assert CORE.chain_finish(*_copy(args)) == out
        if not out:
            continue
        for ia in (3, 4):                              # vk, tk
            x = args[ia].ravel()
            for place in sorted({0, x.size // 2, x.size - 1}):
                for bad in (np.nan, np.inf, -np.inf):
                    a = _copy(args)
                    a[ia].reshape(-1)[place] = bad
                    assert CORE.chain_finish(*a) is False
    # the tent's feeds: 0 (a chain of zero-length moves, no feed floor) is declined
    args, _ = jerk[0]
    a = _copy(args)
    own = a[2]
    a[5][own[-1]] = 0.0                              # D: the last row's chain has no length,
    a[3][-1] = 0.0                                   # vk: nor speed
    assert a[12].size == chains._cf_consts(auto_profile(str(SAMPLES / "prusa_gyroid.gcode")).profile).size
    a[12][7] = 0.0                                   # K: MIN_FEED_V (CK_MINFEED) 0: a feed of 0
    assert CORE.chain_finish(*a) is False
    a[12][7] = 1e-9                                  # (the same with a floor above 0: taken)
    assert CORE.chain_finish(*a) is True
