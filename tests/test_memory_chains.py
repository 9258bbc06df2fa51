"""Issue 8 (memory, round 2): a chain's memory (chains.ChainMemo) answers as the dict it
replaced ({predicted T: law T, ("law", T, beta): (kept, row), "seg": ...}, the latest write
winning); a _KeptPlans reads its rows out of arrays shared by its group as the per-chain
views did; the default `process` does not import scipy (its interpolate/optimize/special
cost ~40 MB of RSS and were only called by reports and tests)."""
import os
import random
import subprocess
import sys

import numpy as np

from gcode_opt import chains

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_chain_memo_answers_as_the_dict_it_replaced():
    rng = random.Random(8)
    vals = [0.5, 1.0, 1.25, 2.0, -0.0, 0.0, 3.0, 1e300]        # few values: keys repeat and collide
    for _ in range(200):
        memo, ref = chains.ChainMemo(), {}
        for _ in range(rng.randrange(0, 12)):
            t, T, b = rng.choice(vals), rng.choice(vals), rng.choice(vals)
            kept, r = object(), rng.randrange(5)
            memo.put(t, T, b, kept, r)
            ref[t] = T
            ref[("law", T, b)] = (kept, r)
        for t in vals + [7.0]:
            assert memo.law_of(t) == ref.get(t, t)
            for b in vals:
                got, want = memo.plan_of(t, b), ref.get(("law", t, b))
                assert (got is None) == (want is None)
                if want is not None:
                    assert got[0] is want[0] and got[1] == want[1]


class _St:
    def __init__(self, ends):
        self.ends_d = ends


def test_kept_plans_rows_of_a_shared_group():
    rng = np.random.default_rng(3)
    ks, n = [2, 3, 1], 4
    R = sum(ks)
    base = (rng.random((R, n + 1)), rng.random((R, n)), rng.random((R, n)), rng.random(R), rng.random(R))
    lo = 0
    for k in ks:
        ends = [1.0, 2.5, 3.0, 4.25]
        kp = chains._KeptPlans(("key",), ends, base, lo, k)
        for j, f in enumerate(("vk", "acc", "feed", "t_pred", "a2_pred")):
            assert np.array_equal(getattr(kp, f), base[j][lo:lo + k])
        assert kp.sk.tolist() == [0.0] + ends
        for r in range(k):
            p = kp.plan(r)
            assert np.array_equal(p.s, kp.sk) and np.array_equal(p.v, base[0][lo + r])
            assert np.array_equal(p.accel, base[1][lo + r]) and np.array_equal(p.feed, base[2][lo + r])
            assert p.time_t == base[3][lo + r] and p.int_a2 == base[4][lo + r]
        lo += k
    whole = chains._KeptPlans(("key",), [1.0], base)          # _finish_rows: all rows its own
    assert whole.k == R and np.array_equal(whole.acc, base[1])


def test_default_process_does_not_import_scipy(tmp_path):
    src = os.path.join(ROOT, "sample_gcode", "prusa_klipper.gcode")
    code = ("import sys; from gcode_opt.cli import main\n"
            f"rc = main(['process', {src!r}, '-o', {str(tmp_path / 'o.gcode')!r}, '-q'])\n"
            "print(rc, sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr
    rc, mods = out.stdout.strip().split(" ", 1)
    assert rc in ("0", "None") and mods == "[]", out.stdout


def test_curve_geom_pts_reads_the_strokes_vertices():
    from gcode_opt import curves
    from gcode_opt.strokes import Points

    class St:
        pts = Points((0.0, 0.0, 1.0, 0.25, 2.0, 0.0, 3.0, 0.5))
    pts, d, u = curves._segments(St)
    g = curves.CurveGeom.__new__(curves.CurveGeom)
    g._b, g._k = curves._Blk(d[None], None, None, None, None, None, None, None, False, pts=[St.pts]), 0
    assert np.array_equal(g.pts, pts) and g.pts.shape == (4, 2)
