"""chains.finish_groups (chains with the same number of segments finished together, their
candidate rows stacked) gives every chain the same numbers, bit for bit, as finishing it
alone (chains._finish_rows), on real gyroid chains under classic jerk (with and without
a finite planner buffer) and Klipper's square-corner velocity."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.detect import auto_profile
from gcode_opt.pipeline import Options, analyse
from gcode_opt.schedule import plan_inputs
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CHAIN

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


def _chains(tmp_path, name, lines=9000):
    src = SAMPLES / name
    head = tmp_path / name                       # the file's first lines: enough chains, quick
    with open(src) as fh:
        head.write_text("".join(fh.readlines()[:lines]))
    prof = auto_profile(str(src)).profile
    strokes, _ = analyse(str(head), prof, Options())
    plan_inputs(strokes, prof, Options())
    return [s for s in strokes if chains.plan_kind(s) == K_CHAIN], prof


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes()


@pytest.mark.parametrize("name,buffer", [("prusa_gyroid_fullspeed.gcode", None),
                                         ("prusa_gyroid_fullspeed.gcode", 16),
                                         ("prusa_gyroid_fullspeed_klipper.gcode", None)])
def test_finish_groups_equal_chain_by_chain(tmp_path, name, buffer):
    sts, prof = _chains(tmp_path, name)
    if buffer is not None:
        prof = dataclasses.replace(prof, block_buffer=buffer)
    assert prof.junction in chains.GROUP_JUNCTIONS
    sts = sts[:80]
    assert len(sts) >= 20
    n_seg = [st.curv.d.size for st in sts]
    assert len(set(n_seg)) < len(n_seg)          # some groups hold several chains
    rules = SegmentRules.for_profile(prof, 10)
    T0 = np.array([st.time_t for st in sts])
    items = [(st, []) for st in sts]
    for r in (1.0, 1.05, 1.25):
        T = T0 * r
        for (st, laws), law in zip(items, chains.solve(sts, T, (T / chains.GAMMA_MIN) ** 2, prof)):
            laws.append(law)
    items = [(st, [lw for lw in laws if lw.converged]) for st, laws in items]
    items = [it for it in items if it[1]]
    got = chains.finish_groups(items, rules, prof)
    for (st, laws), (kept, fits) in zip(items, got):
        want, want_fits = chains._finish_rows(st, laws, rules, prof)
        assert _same(fits, want_fits)
        for f in ("sk", "vk", "acc", "feed", "t_pred", "a2_pred"):
            assert _same(getattr(kept, f), getattr(want, f)), f
        assert kept.key == want.key
