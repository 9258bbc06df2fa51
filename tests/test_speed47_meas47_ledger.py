"""The measure's ledger at a stop: SimResult.take_stop() (the compiled core's) and
_take_stop (the Python model's) give what _LedgerWriter.stopped read attribute by
attribute before (the peaks, then the peaks zeroed, and _sums(res)), the sums as the bytes
of the Ledger's array("d"); and a whole ledger pass writes the same Ledger, bit for bit,
as the writer it replaced (kept here verbatim as the reference)."""
from __future__ import annotations

import os
import random
import re
from array import array

import pytest

from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

SAMPLE = os.path.join(os.path.dirname(__file__), "..", "sample_gcode", "prusa_gyroid.gcode")
needs_core = pytest.mark.skipif(fw._core is None, reason="compiled firmware core not built")


# ---------------------------------------------------------------- the replaced code (verbatim)
def _ref_stopped(self, idx):
    """The model stands empty after line idx."""
    res = self.res
    if res.peak_v > self.carry_v:
        self.carry_v = res.peak_v
    if res.peak_a > self.carry_a:
        self.carry_a = res.peak_a
    res.peak_v = res.peak_a = 0.0
    self.last = (idx, self.snap(), fw._sums(res))
    self.last_j = -1
    pending = self.pending
    if pending:
        led = self.led
        if self.w_last[pending[-1]] >= idx:          # a stop inside a watched range
            led.ok = False
        self.last_j = led._commit(idx, self.last[1], self.last[2], self.carry_v, self.carry_a)
        self.carry_v = self.carry_a = 0.0
        led.hi.extend(fw._repeat(self.last_j, len(pending)))
        self.pending = []


def _ref_commit(self, line, state, sums, peak_v, peak_a):
    self.line.append(line)
    self.state.append(state)
    self.sums.extend(sums)
    self.peak_v.append(peak_v)
    self.peak_a.append(peak_a)
    return len(self.line) - 1


def _ref_init_last(self, led, watch, state, res):
    _init(self, led, watch, state, res)
    self.last = (-1, self.snap(), fw._sums(res))


def _ref_finish(self, n_lines, sim):
    led, res = self.led, self.res
    led.n_lines = n_lines
    sim.stop()
    carry_v, carry_a = max(self.carry_v, res.peak_v), max(self.carry_a, res.peak_a)
    end_j = led._commit(led.n_lines - 1, self.snap(), fw._sums(res), carry_v, carry_a)
    led.hi.extend(fw._repeat(end_j, len(self.pending)))
    if self.wi < self.n_w:
        led.ok = False
    res.peak_v = max(led.peak_v) if len(led.peak_v) else 0.0
    res.peak_a = max(led.peak_a) if len(led.peak_a) else 0.0


_init = fw._LedgerWriter.__init__


def _old_take(res):
    """What stopped read before, in its order: the peaks, the peaks zeroed, the sums."""
    peak_v, peak_a = res.peak_v, res.peak_a
    res.peak_v = res.peak_a = 0.0
    return peak_v, peak_a, array("d", fw._sums(res)).tobytes()


def _results():
    yield fw._CSimResult() if fw._core is not None else None
    yield fw.SimResult()


@pytest.mark.parametrize("seed", range(6))
def test_take_stop_reads_what_stopped_read(seed):
    rng = random.Random(seed)
    for make in (lambda: fw._CSimResult(), fw.SimResult) if fw._core is not None else (fw.SimResult,):
        a, b = make(), make()
        for name in fw._SUMS + ("peak_v", "peak_a"):
            if name in fw._INT_SUMS:
                v = rng.choice([0, 1, rng.randrange(1 << 40), (1 << 53) - 1, (1 << 53) + 1, -(1 << 60) - 3])
            else:
                v = rng.choice([0.0, -0.0, rng.uniform(-1e6, 1e6), float("inf"), 1e-310, rng.random()])
            setattr(a, name, v)
            setattr(b, name, v)
        take = getattr(a, "take_stop", None) or (lambda r=a: fw._take_stop(r))
        got, want = take(), _old_take(b)
        assert type(got[2]) is bytes and len(got[2]) == 8 * fw._N_SUMS
        assert repr(got[:2]) == repr(want[:2]) and got[2] == want[2]
        assert (a.peak_v, a.peak_a) == (0.0, 0.0) and fw.SimResult.as_dict(a) == fw.SimResult.as_dict(b)


def _ledger(path, profile, watch, ref, monkeypatch):
    with monkeypatch.context() as m:
        if ref:
            m.setattr(fw, "USE_QUIET_CORE", False)     # (every stop through the reference's stopped)
            m.setattr(fw._LedgerWriter, "stopped", _ref_stopped)
            m.setattr(fw._LedgerWriter, "__init__", _ref_init_last)
            m.setattr(fw._LedgerWriter, "finish", _ref_finish)
            m.setattr(fw.Ledger, "_commit", _ref_commit)
        recs = []
        res, led = fw.simulate_ledger(path, profile, watch, on_line=lambda r: recs.append(fw.LineRecord.as_dict(r)))
    return (repr(fw.SimResult.as_dict(res)), list(led.line), re.sub(r" at 0x[0-9a-f]+", "", repr(led.state)), led.sums.tobytes(),
            led.peak_v.tobytes(), led.peak_a.tobytes(), list(led.lo), list(led.hi), list(led.stop_lines),
            led.n_lines, led.ok, repr(recs))


@pytest.mark.parametrize("core", ["c", "python"])
@pytest.mark.parametrize("seed", [1, 7])
def test_ledger_pass_is_the_replaced_writer(core, seed, monkeypatch):
    if core == "c" and fw._core is None:
        pytest.skip("compiled firmware core not built")
    with open(SAMPLE, encoding="utf-8", errors="surrogateescape", newline="") as fh:
        n = sum(1 for _ in fh)
    rng = random.Random(seed)
    watch, line = [], rng.randint(0, 40)
    while line < n + 3:
        last = line + rng.randint(0, 60)
        watch.append((line, last))
        line = last + rng.randint(1, 400)
    profile = load_profile("prusa-mk3s")
    old = fw.use_core(core)
    try:
        got = _ledger(SAMPLE, profile, watch, False, monkeypatch)
        want = _ledger(SAMPLE, profile, watch, True, monkeypatch)
    finally:
        fw.use_core(old)
    assert len(want[1]) > 20                     # stops committed
    assert got == want
