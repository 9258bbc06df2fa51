"""stroke_store.StrokeStore: every stroke of every sample (and edge file, and the two corpus
plates: slow) comes back equal in every field after a spill, compiled and pure, from the
file and from memory, after analyse and after plan_inputs (chains); column, take, rewrite.

"Equal" is checked here independently of the store's code: a float by its bits (NaN, -0.0
kept), an int / bool / None by type and value, a shared str / Limits as the SAME object, an
array("d") / Points by type and bytes (a new object), an Arc slot by slot; curv restored
None, chain_T None or an empty ChainMemo."""
import glob
import os
import struct
import subprocess
import sys
from array import array
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import features as feat, stroke_store as ss, strokes as stm
from gcode_opt.chains import ChainMemo
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.state import Arc, Limits

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = sorted(glob.glob(str(ROOT / "sample_gcode/*.gcode")) + glob.glob(str(ROOT / "sample_gcode/edge/*.gcode")))
CORPUS = Path.home() / ".cache/gcode-opt-corpus"
COMPILED = stm._BASE is not None and hasattr(stm._CORE, "store_encode")
PATHS = [False, True] if COMPILED else [True]          # pure: the Python twin
_UNSET = object()


def _same_value(x, y, where):
    """y (restored) equals x (the original), independently of stroke_store"""
    tx = type(x)
    assert type(y) is tx, (where, x, y)
    if tx is float:
        assert struct.pack("=d", x) == struct.pack("=d", y), (where, x, y)
    elif tx in (int, bool) or x is None:
        assert x == y, (where, x, y)
    elif tx is str or tx is Limits:
        assert y is x, (where, "not the same shared object")
    elif tx is array:
        assert y is not x and y.typecode == x.typecode and y.tobytes() == x.tobytes(), where
    elif tx is stm.Points:
        assert y is not x and type(y.xy) is array and y.xy.tobytes() == x.xy.tobytes(), where
    elif tx is Arc:
        for nm in Arc.__slots__:
            _same_value(getattr(x, nm), getattr(y, nm), f"{where}.{nm}")
    else:
        raise AssertionError(f"{where}: unexpected {tx}")


def check_same(orig, back):
    assert len(orig) == len(back)
    for r, (a, b) in enumerate(zip(orig, back)):
        assert type(b) is type(a) and b is not a
        for f in stm.FIELDS:
            x, y = getattr(a, f, _UNSET), getattr(b, f, _UNSET)
            where = f"stroke {r}.{f}"
            if x is _UNSET:
                assert y is _UNSET, where
            elif f == "curv":
                assert y is None, where
            elif f == "chain_T":
                if x is None:
                    assert y is None, where
                else:
                    assert type(y) is ChainMemo and y is not x and y.figs is None and y.n == 0, where
            else:
                _same_value(x, y, where)


def _strokes(path):
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(path)[0])
    sts, _ = analyse(path, prof, opts)
    return sts, (lambda: plan_inputs(sts, prof, opts))


def _roundtrip(sts, pure, in_memory):
    with ss.StrokeStore(in_memory=in_memory, pure=pure) as store:
        store.append(sts[:len(sts) // 3])          # (two appends: indices run on)
        store.append(sts[len(sts) // 3:])
        assert len(store) == len(sts)
        check_same(sts, store.load(0, len(store)))
        return bytes(store._io.data) if in_memory else None


def roundtrip_file(path):
    """Both phases, every path and backend; the compiled and the pure records the same bytes."""
    sts, plan = _strokes(path)
    for phase in ("analyse", "plan_inputs"):
        if phase == "plan_inputs":
            plan()
        got = {}
        for pure in PATHS:
            for in_memory in (False, True):
                got[pure, in_memory] = _roundtrip(sts, pure, in_memory)
        if COMPILED:
            assert got[False, True] == got[True, True], "compiled and pure records differ"
    return sts


@pytest.mark.parametrize("path", SAMPLES, ids=[os.path.relpath(p, ROOT / "sample_gcode") for p in SAMPLES])
def test_roundtrip_samples(path):
    sts = roundtrip_file(path)
    assert sts or "edge" in path


def test_samples_cover_arcs_curves_chains():
    sts, plan = _strokes(str(ROOT / "sample_gcode/prusa_gyroid_arcs.gcode"))
    plan()
    kinds = {s.kind for s in sts}
    assert {stm.K_ARC, stm.K_CURVE, stm.K_LINE} <= kinds
    assert any(s.chain_T is not None for s in sts) and any(s.arc is not None for s in sts)
    assert any(s._ends is not None for s in sts) and any(s.curv is not None for s in sts)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["plate_rectilinear", "plate_gyroid"])
def test_roundtrip_plates(name):
    path = CORPUS / f"{name}.gcode"
    if not path.exists():
        pytest.skip("corpus plate not downloaded")
    roundtrip_file(str(path))


def test_pure_python_strokes_subprocess():
    """With the core off (GCODE_OPT_PURE_PYTHON=1) strokes are plain slotted objects: the
    twin stores and restores them (both phases, file and memory)."""
    code = ("import sys; sys.path.insert(0, 'tests'); import test_speed50_store50_roundtrip as t; "
            "from gcode_opt import strokes as stm; assert stm._BASE is None; "
            "t.roundtrip_file('sample_gcode/prusa_gyroid_arcs.gcode'); "
            "t.roundtrip_file('sample_gcode/edge/arc_variants.gcode'); print('ok')")
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1", PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-3000:]


# ---------------------------------------------------------------- odd values, by hand
def _odd_strokes():
    """Strokes of a sample given every kind of value a field may hold."""
    sts, plan = _strokes(str(ROOT / "sample_gcode/prusa_gyroid_arcs.gcode"))
    plan()
    arc = next(s for s in sts if s.arc is not None)
    curve = next(s for s in sts if s.pts is not None)
    a, b, c, d = sts[:4]
    a.x0, a.v0, a._pux, a._puy = float("nan"), -0.0, float("nan"), None
    a._nux, a._nuy, a._ss_e = float("inf"), -float("inf"), None
    a.v0_fw, a.v1_fw, a.corner_cmd0, a.corner_cmd1 = 12.5, float("nan"), True, False
    a.first_idx, a.last_idx, a.layer = 2**62, -5, 2**40
    b.z, b._ss_a, b._ss_c = None, 3, True                 # (an int, a bool where a float is usual)
    b._ends, b.pts = array("d"), stm.Points()             # empty ones
    c.chain_T = ChainMemo()
    c.chain_T.n = 3                                       # (a memo restored empty)
    del d.curv                                            # an unset object slot stays unset
    del d.pts
    arc.arc.cw, arc.arc.off_circle = True, True
    return sts, [a, b, c, d, arc, curve]


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("in_memory", [False, True])
def test_odd_values(pure, in_memory):
    sts, odd = _odd_strokes()
    with ss.StrokeStore(in_memory=in_memory, pure=pure) as store:
        store.append(odd)
        back = store.load(0, len(store))
    check_same(odd, back)
    assert back[0].corner_cmd0 is True and back[0]._puy is None and back[0]._pux != back[0]._pux
    assert not hasattr(back[3], "pts") and not hasattr(back[3], "curv")
    assert back[4].arc.cw is True and back[4].arc.off_circle is True


def _refused(pure, make):
    sts, _ = _strokes(str(ROOT / "sample_gcode/prusa_gyroid.gcode"))
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts[:5])
        make(sts[7])
        with pytest.raises(TypeError, match="StrokeStore: stroke"):
            store.append(sts[5:10])
        assert len(store) == 5 and store.nbytes > 0     # (left as it was)
        check_same(sts[:5], store.load(0, 5))


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("how", ["np_float_double", "np_float_slot", "big_int", "list", "deleted",
                                 "curve_geom_in_chain", "int_for_float"])
def test_unexpected_types_refused(pure, how):
    def make(st):
        if how == "np_float_double":
            st.x0 = np.float64(1.0)
        elif how == "np_float_slot":
            st.v_feed = np.float64(1.0)
        elif how == "big_int":
            st.layer = 2**70
        elif how == "list":
            st.arc = [1.0]
        elif how == "deleted":
            del st.v0
        elif how == "curve_geom_in_chain":
            st.chain_T = object()
        elif how == "int_for_float":
            st.length_d = 3
    _refused(pure, make)


# ---------------------------------------------------------------- column, take, rewrite
def _field_expect(sts, name):
    vals = [getattr(s, name) for s in sts]
    none = np.array([v is None for v in vals])
    if name in ss.INT_COLUMNS:
        return np.array([int(v) for v in vals], np.int64), none
    return np.array([np.nan if v is None else float(v) for v in vals], np.float64), none


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("in_memory", [False, True])
def test_column(pure, in_memory):
    sts, odd = _odd_strokes()
    sts = [s for s in sts if hasattr(s, "pts")]
    with ss.StrokeStore(in_memory=in_memory, pure=pure) as store:
        store.append(sts)
        for name in sorted(ss.FLOAT_COLUMNS | ss.INT_COLUMNS):
            exp, none = _field_expect(sts, name)
            got, got_none = store.column(name, with_none=True)
            assert got.dtype == exp.dtype, name
            # bit for bit where a value was there (a stored NaN too); NaN where None
            have = ~none
            assert got[have].tobytes() == exp[have].tobytes(), name
            assert np.isnan(got[none]).all(), name
            assert (got_none == none).all(), name
            assert store.column(name).tobytes() == got.tobytes()
        with pytest.raises(ValueError):
            store.column("pts")


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("in_memory", [False, True])
def test_take(pure, in_memory):
    sts, plan = _strokes(str(ROOT / "sample_gcode/prusa_gyroid_arcs.gcode"))
    plan()
    rng = np.random.default_rng(50)
    with ss.StrokeStore(in_memory=in_memory, pure=pure) as store:
        store.append(sts)
        for k in (0, 1, 7, 300, len(sts)):
            rows = np.sort(rng.choice(len(sts), k, replace=False)).astype(np.int64)
            check_same([sts[r] for r in rows], store.take(rows))
        rows = rng.permutation(len(sts))[:50]             # (any order)
        check_same([sts[r] for r in rows], store.take(rows))
        check_same(sts[100:131], store.load(100, 131))
        with pytest.raises(IndexError):
            store.take([len(sts)])


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("in_memory", [False, True])
def test_rewrite(pure, in_memory, monkeypatch):
    monkeypatch.setattr(ss, "BATCH", 64)                  # (several batches and runs)
    sts, plan = _strokes(str(ROOT / "sample_gcode/prusa_gyroid_arcs.gcode"))
    rng = np.random.default_rng(8)
    with ss.StrokeStore(in_memory=in_memory, pure=pure) as store:
        store.append(sts)
        n0 = store.nbytes
        plan()                                            # kinds, chains, v0 / v1 after append
        for round_ in range(3):
            rows = np.sort(rng.choice(len(sts), 400, replace=False)).astype(np.int64)
            for q, r in enumerate(rows.tolist()):
                s = sts[r]
                s.v0, s.v1 = s.v0 * 0.5 + round_, float(q)
                if q % 3 == 0:                            # a longer record: v0_fw None -> a float
                    s.v0_fw, s.corner_cmd0 = 1.0 + q, True
                if q % 5 == 0 and round_ == 2:            # and back: shorter
                    s.v0_fw = None
            store.rewrite(rows, [sts[r] for r in rows.tolist()])
        # strokes changed by plan_inputs but never rewritten are stored as appended: rewrite them all
        store.rewrite(np.arange(len(sts), dtype=np.int64), sts)
        check_same(sts, store.load(0, len(store)))
        assert store.nbytes > n0                          # (longer records went after the end)
        exp, _ = _field_expect(sts, "v0")
        assert store.column("v0").tobytes() == exp.tobytes()
        with pytest.raises(ValueError):
            store.rewrite([0, 1], sts[:1])
