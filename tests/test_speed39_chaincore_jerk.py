"""Session 39 (chaincore): chain_finish's jerk junction (_predict_group with the "jerk" law:
chains._safe_speed of each move, chains._jerk_junction_v of each junction, capped by both
feeds) is one vector loop (cf_jerk_caps, laws/_chaincore.c) where it was a scalar helper per
junction: each candidate made, then selected, as numpy's np.where does.  The same operations on
the same numbers: on the real batches of test_speed21_chainfin_core (the jerk profile, with and
without its planner buffer) and on those batches with the chains' jerk limits scaled down and up
(every junction limited, none, one axis only, the axes unequal), chain_finish must give the numpy
path's bits."""
import copy
import dataclasses

import pytest

from gcode_opt import chains

from test_speed21_chainfin_core import CORE, _batches, _numpy, _same  # noqa: E402

pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "chain_finish"), reason="no chain core")

JERK_SCALES = [(1.0, 1.0), (0.02, 0.02), (0.2, 0.2), (0.6, 1.7), (0.1, 0.03), (0.03, 0.1), (5.0, 5.0), (50.0, 50.0),
               (0.05, 40.0), (40.0, 0.05)]


def _with_jerk(b, sx, sy):
    """Batch b with every chain's jerk limits scaled by sx, sy."""
    sts = []
    for st in b[0]:
        st = copy.copy(st)
        lim = st.lim
        if dataclasses.is_dataclass(lim):
            lim = dataclasses.replace(lim, jerk_x=lim.jerk_x * sx, jerk_y=lim.jerk_y * sy)
        else:
            lim = copy.copy(lim)
            lim.jerk_x, lim.jerk_y = lim.jerk_x * sx, lim.jerk_y * sy
        st.lim = lim
        sts.append(st)
    return (sts,) + tuple(b[1:])


@pytest.mark.parametrize("name", ["mk3s", "mk3s_nobuf"])
def test_jerk_caps_equal_numpy(tmp_path_factory, name):
    bs = _batches(tmp_path_factory, name)
    assert bs[0][6].junction == "jerk"
    rows = 0
    for b in bs:
        if not b[7]:                       # (no junction speeds predicted: cf_jerk_caps not run)
            continue
        for sx, sy in JERK_SCALES:
            p = _with_jerk(b, sx, sy)
            got = chains._finish_core(*p)
            assert got is not None
            assert _same(got, _numpy(p)), (sx, sy)
            rows += p[3].shape[0]
    assert rows >= 200


def test_jerk_caps_rows_differ_with_the_limits(tmp_path_factory):
    """(The scaled limits change the answers: the comparison above sees the junction caps.)"""
    b = next(b for b in _batches(tmp_path_factory, "mk3s") if b[7])
    outs = [chains._finish_core(*_with_jerk(b, sx, sy)) for sx, sy in JERK_SCALES[:3]]
    assert not _same(outs[0], outs[1]) and not _same(outs[1], outs[2])
