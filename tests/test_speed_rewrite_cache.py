"""emit_stroke's value caches (emit._FEED_TEXTS, emit._ACCEL_CMDS): a feed's F text and an
acceleration's M204 line remembered across blocks give the same bytes and the same
refusals as the reference emitter (test_speed_rewrite_text.ref_emit_stroke, which
formats every segment afresh), whether the tables are cold, warm, or emptied as they fill."""
from __future__ import annotations

import math
import random

import numpy as np
import pytest

from gcode_opt import emit
from test_speed_rewrite_text import RefStrokeText, _synthetic_stroke, ref_emit_stroke


def _emit_both(rng, raws, x0, y0, e0, e_rel, ends, s, accels, feeds):
    flavour = rng.choice(["klipper", "marlin2", "marlin-legacy", "rrf"])
    kw = dict(x0_text=f"{x0:.8f}", y0_text=f"{y0:.8f}", e_rel=e_rel, flavour=flavour,
              accel_restore=1000.0, mcr_restore=0.0, feed_restore_v=30.0, extruding=rng.random() < 0.8,
              header=": replaces x", first_cmds=None)
    if rng.random() < 0.3:              # CRLF lines: the M204 table is per line end
        raws = [r.rstrip("\r\n") + "\r\n" for r in raws]
    got = []
    for cls, fn in ((emit.StrokeText, emit.emit_stroke), (RefStrokeText, ref_emit_stroke)):
        st = cls(raws, kw["x0_text"], kw["y0_text"], 0)
        st.e_start_units = int(round(e0 * 10 ** st.dec_e))
        try:
            got.append(fn(st, ends, s, None, accels, feeds, **kw))
        except Exception as e:          # noqa: BLE001 -- the same refusal, for the same reason
            got.append((type(e).__name__, str(e)))
    return got


@pytest.mark.parametrize("cache_max", [2, 5, 1 << 16])
def test_cached_texts_are_the_reference(monkeypatch, cache_max):
    """Every stroke emitted twice (the second time every value is in the tables, unless a
    small table was emptied in between) equals the reference both times."""
    monkeypatch.setattr(emit, "_CACHE_MAX", cache_max)
    monkeypatch.setattr(emit, "_FEED_TEXTS", {})
    monkeypatch.setattr(emit, "_ACCEL_CMDS", {})
    rng = random.Random(17 + cache_max)
    n_text = 0
    for _ in range(400):
        case = _synthetic_stroke(rng)
        for _again in range(2):
            got, want = _emit_both(random.Random(rng.random()), *case)
            assert got == want, case
            n_text += isinstance(got, str)
        assert len(emit._FEED_TEXTS) <= cache_max
        assert all(len(t) <= cache_max for t in emit._ACCEL_CMDS.values())
    assert n_text > 600


def test_feed_and_accel_near_rounding_edges():
    """Values a hair either side of a tenth (mm/min for F, mm/s^2 for M204), repeated in
    one block and across blocks, and the tiny and huge ones that take the slow formatting."""
    rng = random.Random(3)
    feeds, accels = [], []
    for k in (1, 2, 9, 10, 11, 599, 600, 601, 12345, 99999, 1 << 49, 1 << 50, 1 << 51):
        f = k / 600.0
        feeds += [f, math.nextafter(f, 0.0), math.nextafter(f, math.inf), f + 1e-6 / 600.0]
        a = k / 10.0
        accels += [a, math.nextafter(a, 0.0), math.nextafter(a, math.inf), a + 1e-9 / 10.0]
    feeds += [1e-12, 5e-300, 1e20]
    accels += [1e-12, 5e-300, 1e20]
    raws = ["G1 X10.5 Y10 E.5\n"]
    st0 = RefStrokeText(raws, "10.00000000", "10.00000000", 0)
    for _ in range(3):                  # cold, then warm tables
        for i in range(len(feeds)):
            n = rng.randint(1, 6)
            s = np.linspace(0.0, 0.5, n + 1)
            fs = np.array([feeds[(i + j) % len(feeds)] for j in range(n)])
            acs = np.array([accels[(i + 2 * j) % len(accels)] for j in range(n)])
            for flavour in ("klipper", "rrf"):
                kw = dict(x0_text="10.00000000", y0_text="10.00000000", e_rel=True, flavour=flavour,
                          accel_restore=1000.0, mcr_restore=0.0, feed_restore_v=30.0)
                got = emit.emit_stroke(emit.StrokeText(raws, "10.00000000", "10.00000000", 0),
                                       np.array([0.5]), s, None, acs, fs, **kw)
                want = ref_emit_stroke(st0, np.array([0.5]), s, None, acs, fs, **kw)
                assert got == want, (fs, acs, flavour)


@pytest.mark.parametrize("bad", [0.0, -0.0, -1.0, math.nan, math.inf, -math.inf])
def test_a_refused_value_is_never_remembered(bad):
    """A feed or acceleration the emitter refuses raises the same ValueError every time
    (it is not in a table afterwards to be written by a later block)."""
    raws = ["G1 X10.5 Y10 E.5\n"]
    kw = dict(x0_text="10.00000000", y0_text="10.00000000", e_rel=True, flavour="marlin2",
              accel_restore=1000.0, mcr_restore=0.0, feed_restore_v=30.0)
    s = np.array([0.0, 0.5])
    for what in ("feed", "accel"):
        fs, acs = np.array([bad if what == "feed" else 50.0]), np.array([bad if what == "accel" else 1000.0])
        errs = []
        for _ in range(2):
            with pytest.raises(ValueError) as e:
                emit.emit_stroke(emit.StrokeText(raws, "10.00000000", "10.00000000", 0), np.array([0.5]), s, None,
                                 acs, fs, **kw)
            errs.append(str(e.value))
        assert errs[0] == errs[1]
        assert "not a positive number" in errs[0]
    assert not any(k != k or not (k > 0.0 and math.isfinite(k)) for k in emit._FEED_TEXTS)


# ---------------------------------------------------------------- validator: texts known good
from gcode_opt import validate                                         # noqa: E402
from test_speed_rewrite_text import ref_validate_block, _verdict    # noqa: E402


def _block(accels, feeds, nl="\n"):
    lines = [f"{emit.BEGIN}: replaces 2 lines, kind=line, 2 segments"]
    x = 10.0
    for a, f in zip(accels, feeds):
        x += 1.0
        lines += [f"M204 S{a}", f"G1 X{x:.3f} Y10 E.01 F{f}"]
    lines += ["M204 S1000", "G1 F1800", emit.END, ""]
    return nl.join(lines)


@pytest.mark.parametrize("good_max", [1, 3, 1 << 16])
def test_known_good_texts_keep_the_reference_verdicts(monkeypatch, good_max):
    """A text found good for one acceleration limit is not taken as good for a lower one;
    a refused F or M204 text is never remembered; emptied sets still give the reference
    verdicts.  Each block checked twice (cold, then warm)."""
    monkeypatch.setattr(validate, "_GOOD_MAX", good_max)
    monkeypatch.setattr(validate, "_GOOD_FEEDS", set())
    monkeypatch.setattr(validate, "_GOOD_ACCELS", {})
    rng = random.Random(good_max)
    values = ["1500", "2000", "2000.1", "999.9", "3000", "0", "-0", "-5", "1" * 320, ".5", "5.", "1.2.3", "-"]
    limits = [1000.0, 1900.0, 1999.9, 2000.0, 3000.0, math.inf]
    verdicts = set()
    for _ in range(500):
        n = rng.randint(1, 4)
        text = _block([rng.choice(values) for _ in range(n)], [rng.choice(values) for _ in range(n)])
        limit = rng.choice(limits)
        for _again in range(2):
            geo = None
            got = _verdict(validate.validate_block, text, "marlin-legacy", limit, geo, kind="line")
            want = _verdict(ref_validate_block, text, "marlin-legacy", limit, geo, kind="line")
            assert got == want, (text, limit)
            verdicts.add(got)
        assert len(validate._GOOD_FEEDS) <= max(good_max, 4) + 4
    assert None in verdicts and len(verdicts) >= 4
    for limit, good in validate._GOOD_ACCELS.items():   # every remembered text passes its limit
        assert all(0.0 < float(t) <= limit + 0.1 + 1e-9 for t in good)
    assert all(0.0 < float(t) < math.inf for t in validate._GOOD_FEEDS)
