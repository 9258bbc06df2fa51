"""Shared by the chain tests: a sample's chain strokes analysed once per (file, profile),
and made fresh (empty memos, geometry rebuilt) for a test that plans them."""
import numpy as np

from gcode_opt import chains, curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CHAIN

_CACHE = {}


def chain_strokes(path, prof_name):
    """(strokes, plan inputs, the chain rows, profile) of the file under the profile, cached."""
    key = (path, prof_name)
    if key not in _CACHE:
        prof = load_profile(prof_name)
        opts = Options()
        opts.ringing = False
        strokes, _ = analyse(path, prof, opts)
        pin = plan_inputs(strokes, prof, opts)
        rows = np.array([i for i, s in enumerate(strokes) if chains.plan_kind(s) == K_CHAIN], int)
        _CACHE[key] = (strokes, pin, rows, prof)
    return _CACHE[key]


def fresh_chains(path, prof_name):
    """chain_strokes' with each chain's memo emptied and its geometry made again, and the
    profile's SegmentRules (10 segments)."""
    strokes, pin, rows, prof = chain_strokes(path, prof_name)
    for i in rows.tolist():
        strokes[i].chain_T = chains.ChainMemo()
        strokes[i].curv = None
    curves.build_geoms([strokes[i] for i in rows.tolist()], prof, jerk1=True)
    return strokes, pin, rows, prof, SegmentRules.for_profile(prof, 10)


def float_bits(x):
    """x's doubles as bytes (compares NaNs and signed zeros by their bits)."""
    return np.ascontiguousarray(np.asarray(x, float)).view(np.int64).tobytes()


def synthetic_chains(m, seed, min_vertices, min_cap):
    """m random chain problems (laws.chain.ChainProblem): min_vertices..29 vertices 0.4-1.0 mm
    apart, caps min_cap-60 mm/s, run at a mean 35-70 mm/s, end speeds 10-40 mm/s."""
    from gcode_opt.laws.chain import ChainProblem
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(m):
        n = int(rng.integers(min_vertices, 30))
        s = np.cumsum(rng.uniform(0.4, 1.0, n))
        S = float(s[-1] + rng.uniform(0.3, 1.0))
        caps = rng.uniform(min_cap, 60.0, n)
        T = S / rng.uniform(35.0, 70.0)
        out.append(ChainProblem(s, caps, S, T, (T / 0.1) ** 2, rng.uniform(10, 40), rng.uniform(10, 40)))
    return out
