"""The resonance model (firmware/resonance.py, ringing.py) against independent checks:
scipy's solve_ivp integrating the oscillator piece by piece on real stretches of the
samples, Klipper's own shaper definitions, brute-force sampling of the shaper smoothing,
and the firmware model's print time."""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gcode_opt import ringing
from gcode_opt.firmware.resonance import Oscillator, Response, shaper_pulses, smoothing
from gcode_opt.firmware.simulate import simulate_file
from gcode_opt.profile import ProfileError, load_profile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")
KLIPPY = "/work/shared/klipper/klippy"


def _items(name, prof, first, count):
    """count consecutive planned blocks of a real sample, from block `first` on."""
    rows = []

    def on_block(b):
        rows.append((b.ux, b.uy, b.start_v, b.cruise_v, b.end_v, b.accel, b.accel_t,
                     b.cruise_t, b.decel_t, 1.0 if b.after_stop else 0.0, b.idx, 1.0))

    simulate_file(os.path.join(SAMPLES, name), load_profile(prof), on_block=on_block)
    part = rows[first:first + count]
    # the stretch starts from rest: its first block starts at its own start speed, as a
    # jump from rest (the model and the integrator see the same command)
    return part


def _ode_error(tr, freq_hz, zeta, ax, pulses=None, keep=None, t_eval=None):
    """e(t) = x - x_c by solve_ivp over the (shaped) command, impulses as jumps of e'.
    Returns (e at t_eval, a_c at t_eval, integral of (e + a_c/w^2)^2 dt)."""
    w = 2 * math.pi * freq_hz
    a_p, t_p = pulses if pulses is not None else (np.ones(1), np.zeros(1))
    dv = tr.dv[:, ax] if keep is None else np.where(keep, tr.dv[:, ax], 0.0)
    # the shaped command's acceleration is sum A_i a_c(t - t_i): piecewise constant
    # between the merged breakpoints; its velocity jumps sit at t_k + t_i
    brk = np.unique(np.concatenate([tr.t0 + ti for ti in t_p]))
    brk = np.append(brk, brk[-1] + 1.0)                 # one second of ring-down at rest
    jump_t = np.concatenate([tr.t0 + ti for ti in t_p])
    jump_v = np.concatenate([ai * dv for ai in a_p])

    def acc_at(t):
        out = np.zeros_like(np.asarray(t, float))
        for ai, ti in zip(a_p, t_p):
            k = np.clip(np.searchsorted(tr.t0, np.asarray(t) - ti, side="right") - 1, 0, len(tr) - 1)
            out = out + ai * tr.acc[k, ax]
        return out

    y = np.zeros(3)                                     # e, e', integral of r^2
    e_out = np.full(len(t_eval), np.nan)
    for lo, hi in zip(brk[:-1], brk[1:]):
        at_lo = np.isclose(jump_t, lo, rtol=0, atol=1e-12)
        y[1] -= jump_v[at_lo].sum()
        if hi - lo <= 0:
            continue
        a_c = float(acc_at(np.array([0.5 * (lo + hi)]))[0])

        def f(t, s, a_c=a_c):
            r = s[0] + a_c / (w * w)
            return [s[1], -a_c - 2 * zeta * w * s[1] - w * w * s[0], r * r]

        inside = (t_eval >= lo) & (t_eval < hi)
        sol = solve_ivp(f, (lo, hi), y, method="DOP853", rtol=1e-11, atol=1e-15,
                        dense_output=inside.any())
        if inside.any():
            e_out[inside] = sol.sol(t_eval[inside])[0]
        y = sol.y[:, -1].copy()
    return e_out, acc_at(t_eval), y[2]


def _check_against_ode(name, prof, first, count, freq_hz=50.0, zeta=0.1, shaper="none"):
    tr = ringing.trace_from_items(_items(name, prof, first, count))
    model = dict(freq_x_hz=freq_hz, freq_y_hz=freq_hz * 0.8, damping_r=zeta, shaper=shaper,
                 shaper_freq_x_hz=freq_hz, shaper_freq_y_hz=freq_hz * 0.8, shaper_damping_r=0.1)
    res = ringing.responses(tr, model)
    rng = np.random.default_rng(1)
    t_eval = np.sort(rng.uniform(-0.5, tr.t0[-1] + 0.5, 400))
    for ax, axn in enumerate("xy"):
        f = model[f"freq_{axn}_hz"]
        pulses = shaper_pulses(shaper, model[f"shaper_freq_{axn}_hz"], 0.1)
        e, a_c, int_r2 = _ode_error(tr, f, zeta, ax, pulses, t_eval=t_eval)
        r_ode = e + a_c / (2 * math.pi * f) ** 2
        r_model = res[axn]["all"].at(t_eval)
        scale = np.abs(r_ode).max()
        assert scale > 1e-6                              # the stretch does ring (> 1 um)
        assert np.abs(r_model - r_ode).max() < 1e-6 * scale + 1e-12
        # the exact integral up to the ODE's horizon (1 s after the end: exp(-31) left)
        assert res[axn]["all"].int_r2() == pytest.approx(int_r2, rel=1e-6)
        # the exact peak is at least every sampled value, and not far above the densest sample
        t_dense = np.linspace(-0.5, tr.t0[-1] + 0.5, 200001)
        dense = np.abs(res[axn]["all"].at(t_dense)).max()
        assert res[axn]["all"].peak() >= dense * (1 - 1e-12)
        assert res[axn]["all"].peak() <= dense * 1.001
    return tr, res


def test_exact_ringing_matches_solve_ivp_rectilinear():
    """A stretch of infill and perimeters of the MK3S sample (classic jerk junctions)."""
    _check_against_ode("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 1200, 25)


def test_exact_ringing_matches_solve_ivp_gyroid_klipper_shaped():
    """Gyroid polylines (gentle turns) played by Klipper's planner, through an MZV shaper
    tuned at the resonance: the shaped ODE is driven by sum A_i a_c(t - t_i)."""
    _check_against_ode("prusa_gyroid.gcode", "voron24", 3000, 60, shaper="mzv")


def test_parts_add_up_and_ramp_part_matches_its_own_ode():
    tr = ringing.trace_from_items(_items("prusa_klipper.gcode", "voron24", 800, 30))
    model = ringing.model_of(load_profile("voron24"))
    res = ringing.responses(tr, model)
    t = np.linspace(0, tr.t0[-1], 3000)
    for axn in "xy":
        parts = sum(res[axn][p].at(t) for p in ringing.PARTS)
        assert np.allclose(parts, res[axn]["all"].at(t), rtol=0, atol=1e-12)
    # the ramp part is the response to the accelerations alone (no velocity jumps)
    w = 2 * math.pi * model["freq_x_hz"]
    e, a_c, _ = _ode_error(tr, model["freq_x_hz"], model["damping_r"], 0,
                           keep=np.zeros(len(tr), bool), t_eval=t)
    r_ode = e + a_c / (w * w)
    assert np.abs(res["x"]["ramp"].at(t) - r_ode).max() < 1e-6 * np.abs(r_ode).max()


def test_free_decay_closed_forms():
    """One jump: r(t) = exp(-s t)(r0 cos wd t + ...) by hand; integral and peak by hand."""
    osc = Oscillator(40.0, 0.05)
    resp = Response(osc, np.array([0.0]), np.array([0.0]), np.array([-3.0]))   # dv = 3 mm/s
    t = np.linspace(0, 0.2, 7)
    by_hand = -3.0 / osc.wd * np.exp(-osc.s * t) * np.sin(osc.wd * t)
    assert np.allclose(resp.at(t), by_hand, rtol=1e-12, atol=1e-15)
    # integral of (A e^{-st} sin wd t)^2 over [0, inf) = A^2 wd^2 / (4 s (s^2 + wd^2))
    amp = 3.0 / osc.wd
    assert resp.int_r2() == pytest.approx(amp ** 2 * osc.wd ** 2 / (4 * osc.s * (osc.s ** 2 + osc.wd ** 2)),
                                          rel=1e-12)
    # first extremum: tan(wd t) = wd / s
    t_pk = math.atan2(osc.wd, osc.s) / osc.wd
    assert resp.peak() == pytest.approx(amp * math.exp(-osc.s * t_pk) * math.sin(osc.wd * t_pk), rel=1e-12)


def test_long_file_chunks_keep_precision():
    """Events over 100 s (past the exp(300) restart): the amplitude after a quiet gap is the
    decayed last jump, whatever chunk it falls in."""
    osc = Oscillator(30.0, 0.02)                        # s = 3.8/s: chunks of ~80 s
    t_ev = np.array([0.0, 50.0, 150.0, 150.001])
    resp = Response(osc, t_ev, np.array([1e-3, 2e-3, 1e-3, -1e-3]), np.zeros(4))
    t = np.array([150.0005, 160.0])
    by_hand = 0.0
    for tj, dr in zip(t_ev, [1e-3, 2e-3, 1e-3, -1e-3]):
        c = osc.jump_amplitude(dr, 0.0)
        by_hand = by_hand + np.where(t >= tj, np.real(c * np.exp(osc.lam * (t - tj))), 0.0)
    assert np.allclose(resp.at(t), by_hand, rtol=1e-9, atol=1e-18)


@pytest.mark.skipif(not os.path.isdir(KLIPPY), reason="Klipper checkout absent")
@pytest.mark.parametrize("kind", ["zv", "mzv", "ei"])
@pytest.mark.parametrize("freq,zeta", [(35.0, 0.05), (52.5, 0.1), (80.0, 0.2)])
def test_shapers_are_klippers(kind, freq, zeta):
    sys.path.insert(0, KLIPPY)
    try:
        from extras import shaper_defs
    finally:
        sys.path.remove(KLIPPY)
    a_k, t_k = shaper_defs.init_shaper(kind, freq, zeta)
    a_k = np.asarray(a_k) / np.sum(a_k)
    t_k = np.asarray(t_k) - np.dot(a_k, t_k)           # kin_shaper.c shift_pulses
    a, t = shaper_pulses(kind, freq, zeta)
    assert np.allclose(a, a_k, rtol=1e-9) and np.allclose(t, t_k, rtol=0, atol=1e-12)


def test_smoothing_matches_dense_sampling():
    tr = ringing.trace_from_items(_items("prusa_klipper.gcode", "voron24", 500, 80))
    pulses = [shaper_pulses("mzv", 50.0, 0.1), shaper_pulses("ei", 40.0, 0.1)]

    def pos(t):
        k = np.clip(np.searchsorted(tr.t0, t, side="right") - 1, 0, len(tr) - 1)
        tau = (t - tr.t0[k])[:, None]
        return tr.pos[k] + tr.vel[k] * tau + 0.5 * tr.acc[k] * tau * tau

    t = np.linspace(tr.t0[0], tr.t0[-1], 400001)
    d = np.stack([sum(ai * pos(t - ti)[:, ax] for ai, ti in zip(*pulses[ax])) for ax in (0, 1)], 1) - pos(t)
    n = np.sqrt((d * d).sum(1))
    rms_d, max_d = smoothing(tr.t0, tr.pos, tr.vel, tr.acc, pulses)
    assert n.max() > 1e-3                               # the shaper does smooth (> 1 um)
    assert rms_d == pytest.approx(math.sqrt(np.mean(n * n)), rel=2e-3)
    assert max_d == pytest.approx(n.max(), rel=2e-2)


@pytest.mark.parametrize("name,prof", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_klipper.gcode", "voron24")])
def test_trace_is_the_firmware_models_motion(name, prof):
    """Same print time as the firmware model (blocks, E-only moves and dwells), positions
    and speeds continuous from piece to piece except the recorded jumps."""
    p = load_profile(prof)
    tr = ringing.trace(os.path.join(SAMPLES, name), p)
    assert tr.total_t == pytest.approx(simulate_file(os.path.join(SAMPLES, name), p).time_t, rel=1e-9)
    dur = tr.dur[:-1, None]
    assert np.abs(tr.pos[:-1] + tr.vel[:-1] * dur + 0.5 * tr.acc[:-1] * dur * dur - tr.pos[1:]).max() < 1e-9
    assert np.abs(tr.vel[:-1] + tr.acc[:-1] * dur + tr.dv[1:] - tr.vel[1:]).max() < 1e-9
    # the jumps are corners or gentle turns, never inside a block
    assert not np.any(tr.dv[tr.cls == ringing.NONE])


def test_figures_keys_and_shaper_helps():
    p = load_profile("voron24")
    path = os.path.join(SAMPLES, "prusa_klipper.gcode")
    tr = ringing.trace(path, p)
    model = ringing.model_of(p)
    plain = ringing.figures_of_trace(tr, model, "none")
    mzv = ringing.figures_of_trace(tr, model, "mzv")
    for f in (plain, mzv):
        for ax in "xy":
            assert set(f[ax]) == {f"{k}{part}_um" for k in ("rms", "peak")
                                  for part in ("", "_ramp", "_corner", "_turn")}
    assert "smoothing" not in plain and mzv["smoothing"]["rms_um"] > 0
    assert mzv["xy"]["rms_um"] < 0.5 * plain["xy"]["rms_um"]       # tuned at f: 3-5x less


# ---------------------------------------------------------------- the profile's [resonance]
def _write(tmp_path, extra):
    f = tmp_path / "p.toml"
    f.write_text('[firmware]\nflavour = "klipper"\njunction = "scv"\nsquare_corner_velocity_v = 5.0\n'
                 '[limits]\nmax_velocity_v = 300.0\nmax_accel_a = 3000.0\n' + extra)
    return str(f)


def test_resonance_defaults_when_absent(tmp_path):
    p = load_profile(_write(tmp_path, ""))
    assert (p.freq_x_hz, p.freq_y_hz, p.damping_r, p.shaper) == (50.0, 50.0, 0.1, "none")
    assert (p.shaper_freq_x_hz, p.shaper_freq_y_hz, p.shaper_damping_r) == (50.0, 50.0, 0.1)


def test_resonance_table_read(tmp_path):
    p = load_profile(_write(tmp_path, '[resonance]\nfreq_x_hz = 61.2\nfreq_y_hz = 38\n'
                                      'damping_r = 0.07\nshaper = "ei"\nshaper_freq_y_hz = 41.0\n'))
    assert (p.freq_x_hz, p.freq_y_hz, p.damping_r, p.shaper) == (61.2, 38.0, 0.07, "ei")
    assert (p.shaper_freq_x_hz, p.shaper_freq_y_hz) == (61.2, 41.0)    # x tuned at f


@pytest.mark.parametrize("line,msg", [
    ("freq_x_hz = 0", "freq_x_hz = 0: must be in [1, 1000] Hz"),
    ("freq_y_hz = 5000.0", "freq_y_hz = 5000.0: must be in [1, 1000] Hz"),
    ("damping_r = 1.0", "damping_r = 1.0: must be in (0, 1)"),
    ("damping_r = 0", "damping_r = 0: must be in (0, 1)"),
    ('shaper = "zvd"', "must be one of none, zv, mzv, ei"),
    ('freq_x_hz = "50"', "must be a number in Hz, not a string"),
    ("shaper_damping_r = 0.5", "shaper_damping_r = 0.5: must be in (0, 0.4]"),
])
def test_resonance_schema_refuses(tmp_path, line, msg):
    with pytest.raises(ProfileError, match=msg.replace("(", r"\(").replace(")", r"\)")
                       .replace("[", r"\[").replace("]", r"\]")):
        load_profile(_write(tmp_path, "[resonance]\n" + line + "\n"))


def test_resonance_key_in_wrong_table(tmp_path):
    with pytest.raises(ProfileError, match=r"freq_x_hz belongs under \[resonance\]"):
        load_profile(_write(tmp_path, "freq_x_hz = 50.0\n"))


def test_smoothing_in_chunks_is_the_same(monkeypatch):
    from gcode_opt.firmware import resonance
    tr = ringing.trace_from_items(_items("prusa_klipper.gcode", "voron24", 500, 40))
    pulses = [shaper_pulses("mzv", 50.0, 0.1), shaper_pulses("zv", 45.0, 0.1)]
    whole = smoothing(tr.t0, tr.pos, tr.vel, tr.acc, pulses)
    monkeypatch.setattr(resonance, "SMOOTH_CHUNK", 7)
    parts = resonance.smoothing(tr.t0, tr.pos, tr.vel, tr.acc, pulses)
    assert parts[0] == pytest.approx(whole[0], rel=1e-12) and parts[1] == whole[1]
