"""Review properties (ctl16) of the control layer that ``test_control_properties_ctl14``
does not state: the PID core against a slow textbook reference over irregular intervals,
braking mirroring traction, bumpless gain changes, non-positive intervals, and the
streaming estimators and the measured replay over any grouping of their samples."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from terrain.control.closed_loop import run_closed_loop
from terrain.control.estimators import WheelImuObserver
from terrain.control.feedforward import traction_acceleration_limit
from terrain.control.grid import compare
from terrain.control.replay import measured_observations
from terrain.control.traction import (BRAKING, STEADY, TRACTION, SlipTargets,
                                      TractionControlConfig, TractionState,
                                      traction_control_step)
from terrain.errors import ConfigError, NonNumericError, ShapeError
from terrain.run import Run
from terrain.terramechanics import (get_terrain, soil_resistance_coefficient,
                                    traction_coefficient)
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.terramechanics.resistance import G_M_S2

sys.path.insert(0, str(Path(__file__).parent))
from control_helpers import observation  # noqa: E402

FAST = settings(max_examples=60, deadline=None)
one = (lambda x: np.array([float(x)]))  # noqa: E731

targets_s = st.builds(SlipTargets, traction=st.floats(0.01, 1.0),
                      braking=st.floats(-1.0, -0.01), steady=st.floats(0.0, 1.0))


# --- the PID core against a slow reference ------------------------------------------------

#: one step of an unsaturated two-sided run: (v_long, a_local, slip, dt)
pid_steps = st.tuples(st.sampled_from([-1.0, 1.0]), st.floats(-3.0, 3.0),
                      st.floats(-1.0, 1.0), st.floats(0.01, 0.1))


def _reference_pid(cfg, targets, seq):
    """Textbook PID of eqs. 8.1-8.2 by hand: ``e = sgn(v) target(mode) - s``,
    ``I += ki e dt``, derivative of the measured slip through the first-order filter
    ``d += dt / (tau + dt) (raw - d)`` (raw 0 at the first step), ``PID = kp e + I - kd d``."""
    integral, deriv, s_prev, out = 0.0, 0.0, None, []
    for v, a, s, dt in seq:
        power = a * v
        target = (targets.traction if power > cfg.power_threshold_m2_s3 else
                  targets.braking if power < -cfg.power_threshold_m2_s3 else targets.steady)
        e = (1.0 if v > 0 else -1.0) * target - s        # sgn(v_long) target
        raw = 0.0 if s_prev is None else (s - s_prev) / dt
        deriv += dt / (cfg.derivative_tau_s + dt) * (raw - deriv)
        integral += cfg.ki * e * dt
        out.append(cfg.kp * e + integral - cfg.kd * deriv)
        s_prev = s
    return out


@FAST
@given(st.floats(0.0, 5.0), st.floats(0.0, 2.0), st.floats(0.0, 0.05), st.floats(0.02, 0.5),
       targets_s, st.lists(pid_steps, min_size=1, max_size=30))
def test_unsaturated_pid_equals_the_slow_textbook_reference(kp, ki, kd, tau, targets, seq):
    """Where nothing saturates (two-sided, a command in the middle of a wide range), every
    step's correction is the textbook PID over the *irregular* intervals drawn, mode and
    direction switches included: integral ``sum ki e dt``, filtered derivative of the
    measurement, no other memory."""
    cfg = TractionControlConfig(kp=kp, ki=ki, kd=kd, derivative_tau_s=tau, wheel_radius_m=1.0,
                                omega_max_rad_s=100.0, output_fraction=0.5, one_sided=False)
    state = TractionState.zeros(1)
    expected = _reference_pid(cfg, targets, seq)
    for (v, a, s, dt), want in zip(seq, expected):
        out, state = traction_control_step(cfg, state, targets, one(50.0), one(50.0), one(v),
                                           one(a), 1.0, dt, slip=one(s))
        assert out.enabled[0] and not out.safe[0]
        assert abs(want) < 50.0
        assert out.correction_rad_s[0] == pytest.approx(want, rel=1e-9, abs=1e-9)
        assert out.omega_cmd_rad_s[0] == pytest.approx(50.0 + want, rel=1e-12, abs=1e-9)


@FAST
@given(st.floats(0.1, 5.0), st.floats(0.01, 0.2), st.integers(1, 20), st.floats(-0.5, 0.5),
       st.floats(0.0, 0.3))
def test_the_integral_does_not_depend_on_how_an_interval_is_cut(ki, total, n, error, target):
    """Integral-only control of a constant error: ``n`` steps of ``T / n`` give the same
    correction as one step of ``T`` (``ki e T``), unsaturated."""
    cfg = TractionControlConfig(kp=0.0, ki=ki, omega_max_rad_s=100.0, one_sided=False)
    targets = SlipTargets(max(target, 0.01), -0.1, 0.0)
    s = targets.traction - error
    args = (one(50.0), one(50.0), one(1.0), one(1.0), 1.0)   # traction, v 1 m/s

    def run(steps):
        state = TractionState.zeros(1)
        for _ in range(steps):
            out, state = traction_control_step(cfg, state, targets, *args, total / steps,
                                               slip=one(s))
        return out.correction_rad_s[0]

    assert run(n) == pytest.approx(run(1), rel=1e-9, abs=1e-12)
    assert run(1) == pytest.approx(ki * error * total, rel=1e-9, abs=1e-12)


# --- braking mirrors traction -------------------------------------------------------------

mirror_steps = st.tuples(st.floats(0.5, 5.0), st.floats(-1.0, 1.0), st.floats(1e-3, 0.2),
                         st.booleans())


@FAST
@given(st.floats(0.0, 50.0), st.floats(0.0, 50.0), st.floats(0.0, 2.0), st.floats(0.01, 0.5),
       st.floats(0.05, 0.5), st.booleans(), st.floats(0.01, 1.0), st.floats(0.0, 1.0),
       st.floats(0.1, 3.0), st.lists(mirror_steps, min_size=1, max_size=30))
def test_braking_mirrors_traction(kp, ki, kd, tau, fraction, one_sided, target, steady, v,
                                  seq):
    """Table 8.1: cases 1C/1D mirror 1A/1B. A braking wheel (``a v < 0``) with slip ``-s``
    and braking target ``-t`` gets exactly the opposite correction of a driving wheel
    (``a v > 0``) with slip ``s`` and traction target ``t``, over any history (enable
    toggles included), one- or two-sided, where the command has the same room on either
    side (the limiter then only slows a driving wheel and only speeds up a braking one)."""
    cfg = TractionControlConfig(kp=kp, ki=ki, kd=kd, derivative_tau_s=tau, wheel_radius_m=0.2,
                                omega_max_rad_s=20.0, output_fraction=fraction,
                                one_sided=one_sided)
    drive = SlipTargets(target, -target, min(steady, target))
    ll = one(10.0)          # omega_max / 2: the same room above and below
    st_t, st_b = TractionState.zeros(1), TractionState.zeros(1)
    for a, s, dt, on in seq:
        chassis = 1.0 if on else 0.0
        out_t, st_t = traction_control_step(cfg, st_t, drive, ll, ll, one(v), one(a),
                                            chassis, dt, slip=one(s))
        out_b, st_b = traction_control_step(cfg, st_b, drive, ll, ll, one(v), one(-a),
                                            chassis, dt, slip=one(-s))
        assert (out_t.mode[0], out_b.mode[0]) == (TRACTION, BRAKING)
        assert out_b.desired_slip[0] == -out_t.desired_slip[0]
        assert out_b.correction_rad_s[0] == -out_t.correction_rad_s[0]
        assert st_b.integral[0] == -st_t.integral[0]


# --- bumpless gain changes and the interval -----------------------------------------------

#: a gain of 0 or a usable one (a subnormal ki has ki dt == 0: no integral at all)
gains = st.one_of(st.just(0.0), st.floats(1e-3, 50.0))
configs = st.builds(
    TractionControlConfig, kp=gains, ki=gains, kd=st.just(0.0),
    wheel_radius_m=st.floats(0.05, 1.0), omega_max_rad_s=st.floats(1.0, 30.0),
    output_fraction=st.floats(0.05, 1.0), one_sided=st.booleans())
history = st.lists(st.tuples(st.floats(-25.0, 25.0), st.floats(-3.0, 3.0),
                             st.floats(-5.0, 5.0), st.floats(-1.0, 1.0),
                             st.floats(0.0, 3.0), st.floats(1e-3, 0.2)),
                   min_size=1, max_size=20)


def _history(cfg, targets, seq):
    state = TractionState.zeros(1)
    for wm, v, a, s, ch, dt in seq:
        ll = min(max(wm, -cfg.omega_max_rad_s), cfg.omega_max_rad_s)
        _, state = traction_control_step(cfg, state, targets, one(ll), one(wm), one(v),
                                         one(a), ch, dt, slip=one(s))
    return state


@FAST
@given(configs, targets_s, history, gains, gains, st.floats(1e-3, 0.2))
def test_a_gain_change_at_zero_error_does_not_bump_the_output(cfg, targets, seq, kp, ki, dt):
    """Bumpless retuning: the integral holds rad/s (the output it applies), not the sum of
    the errors, so changing kp or ki between two steps with a zero error (kd 0) gives the
    same correction as keeping the gains."""
    state = _history(cfg, targets, seq)
    v = 0.5
    ll = one(0.5 * cfg.omega_max_rad_s)
    probe, _ = traction_control_step(cfg, TractionState.zeros(1), targets, ll, ll, one(v),
                                     one(2.0), 1.0, dt, slip=one(0.0))
    desired = probe.desired_slip[0]          # traction mode (a v = 1 > threshold)
    outs = []
    for c in (cfg, dataclasses.replace(cfg, kp=kp, ki=ki)):
        out, _ = traction_control_step(c, state, targets, ll, ll, one(v), one(2.0), 1.0, dt,
                                       slip=one(desired))
        assert out.error[0] == 0.0 and out.enabled[0]
        outs.append(out.correction_rad_s[0])
    if state.active[0] or (cfg.ki > 0.0) == (ki > 0.0):
        assert outs[0] == outs[1]


@FAST
@given(configs, targets_s, history, st.one_of(st.just(0.0), st.just(-0.0),
                                              st.floats(-10.0, -1e-12)))
def test_a_zero_or_negative_interval_gives_the_safe_output(cfg, targets, seq, dt):
    """``dt_s`` <= 0 (a repeated or back-going time stamp): no correction, ``safe``, memory
    cleared, whatever came before (the PID would divide by it or integrate backwards)."""
    state = _history(cfg, targets, seq)
    ll = 0.5 * cfg.omega_max_rad_s
    out, new = traction_control_step(cfg, state, targets, one(ll), one(ll), one(0.5),
                                     one(1.0), 1.0, dt, slip=one(0.9))
    assert out.safe[0] and not out.enabled[0]
    assert out.correction_rad_s[0] == 0.0 and out.omega_cmd_rad_s[0] == ll
    assert new.integral[0] == 0.0 and new.derivative[0] == 0.0 and not new.active[0]


@FAST
@given(configs, targets_s, history)
def test_the_steady_mode_uses_the_steady_target_only_two_sided(cfg, targets, seq):
    """Eq. 8.9: within the power dead band the set point is the steady target for the
    two-sided regulation, the traction target for the one-sided limiter (its steady limit)."""
    state = _history(cfg, targets, seq)
    ll = one(0.5 * cfg.omega_max_rad_s)
    for v in (0.5, -0.5):
        out, _ = traction_control_step(cfg, state, targets, ll, ll, one(v), one(0.0), 1.0,
                                       0.01, slip=one(0.0))
        assert out.mode[0] == STEADY
        want = targets.traction if cfg.one_sided else targets.steady
        assert out.desired_slip[0] == (want if v > 0 else -want)


# --- the wheel + IMU observer over any grouping of its samples ----------------------------

def _observer_stream(draw_rows):
    imu = np.array([[t, a, 0.0, w] for t, a, w, _, _ in draw_rows])
    wheels = np.array([[t + 0.002, wl, wr] for t, _, _, wl, wr in draw_rows])
    return imu, wheels


sample_rows = st.lists(st.tuples(st.floats(-2.0, 2.0), st.floats(-0.5, 0.5),
                                 st.floats(-5.0, 5.0), st.floats(-5.0, 5.0)),
                       min_size=2, max_size=30)


@FAST
@given(sample_rows, st.lists(st.integers(1, 29), max_size=6), st.floats(0.005, 0.1))
def test_wheel_imu_observer_does_not_depend_on_how_samples_are_grouped_into_calls(
        rows, cuts, period):
    """Sample-by-sample processing: the same time-ordered IMU and wheel samples handed over
    in one call or in any number of calls give the same final speed (the robot is
    commanded to move, so no zero-velocity update depends on the call)."""
    rows = [(k * period, a, w, wl, wr) for k, (a, w, wl, wr) in enumerate(rows)]
    imu, wheels = _observer_stream(rows)
    t_end = rows[-1][0] + 0.01

    def run(bounds):
        est = WheelImuObserver()
        lo = 0
        for hi in [*bounds, len(rows)]:
            out = est.update(observation(rows[min(hi, len(rows)) - 1][0] + 0.01
                                         if hi < len(rows) else t_end, [1.0, 1.0],
                                         imu=imu[lo:hi], wheels=wheels[lo:hi]))
            lo = hi
        return out

    whole = run([])
    split = run(sorted({c for c in cuts if c < len(rows)}))
    np.testing.assert_allclose(split.v_long_m_s, whole.v_long_m_s, rtol=1e-12, atol=1e-12)
    assert split.age_s == whole.age_s


@FAST
@given(st.floats(-2.0, 2.0), st.floats(0.0, 3.0), st.floats(0.01, 5.0), st.floats(0.01, 2.0))
def test_a_late_wheel_sample_never_pushes_the_speed_away_from_its_reference(
        v0, v_ref, back, tau):
    """The pull ``v += (1 - exp(-dt / tau)) (v_ref - v)`` moves the speed towards the
    wheel's reference, never past it nor away from it: a wheel sample stamped ``back`` s
    *before* the previous one (a late sample; ``dt < 0``) may not reverse it
    (``1 - exp(|dt| / tau)`` is negative: it pushed the speed away, by more than the gap for
    ``|dt| > tau ln 2``: v 0, v_ref 1 m/s, 1 s late, tau 1 s: -1.72 m/s)."""
    est = WheelImuObserver(tau_s=tau)
    r = est.vehicle.wheel_radius_m
    est.update(observation(1.0, [1.0, 1.0], wheels=np.array([[1.0, v0 / r, v0 / r]])))
    est.v = before = v0              # (the first sample's own pull: none, dt 0)
    late = np.array([[1.0 - back, v_ref / r, v_ref / r]])
    est.update(observation(1.1, [1.0, 1.0], wheels=late))
    lo, hi = sorted((before, v_ref))
    assert lo - 1e-12 <= est.v <= hi + 1e-12
    assert est.update(observation(1.1, [1.0, 1.0])).age_s == pytest.approx(0.1)


@FAST
@given(st.floats(0.1, 5.0), st.floats(0.01, 3.0), st.floats(-5.0, 5.0))
def test_a_late_imu_sample_does_not_integrate_backwards(t_prev, back, accel):
    """``v += dt a_x``: an accelerometer sample stamped before the previous one (a late
    sample) may not integrate over a negative interval (a forward acceleration then slowed
    the robot: ``a`` 1 m/s^2, 2 s late, -2 m/s)."""
    est = WheelImuObserver()
    est.update(observation(t_prev, [1.0, 1.0], imu=np.array([[t_prev, 0.0, 0.0, 0.0]])))
    v_before = est.v
    est.update(observation(t_prev + 0.01, [1.0, 1.0],
                           imu=np.array([[t_prev - back, accel, 0.0, 0.0]])))
    assert est.v == v_before
    # and the next in-order sample integrates from the latest time, not the late one
    est.update(observation(t_prev + 0.02, [1.0, 1.0],
                           imu=np.array([[t_prev + 0.01, accel, 0.0, 0.0]])))
    assert est.v == pytest.approx(v_before + 0.01 * accel, abs=1e-12)


# --- the measured replay: every logged sample once ----------------------------------------

times = st.lists(st.floats(0.0, 3.0), min_size=1, max_size=40).map(sorted)


@FAST
@given(times, times, st.floats(1.0, 200.0))
def test_every_logged_sample_reaches_one_call_or_is_counted_dropped(t_imu, t_wh, rate):
    """Conservation: each stream's samples are the ones handed to the calls (each once, in
    order, within ``(previous call, call]``) plus those counted before the start and after
    the end, whatever the clocks (repeated times included) and the rate."""
    assume(max(t_imu[0], t_wh[0]) <= min(t_imu[-1], t_wh[-1]))
    imu = pd.DataFrame({"t_s": t_imu, "wx": 0.0, "wy": 0.0, "wz": 0.0,
                        "ax": np.arange(len(t_imu), dtype=float), "ay": 0.0, "az": 9.81})
    wh = pd.DataFrame({"t_s": t_wh, "vel_l": np.arange(len(t_wh), dtype=float), "vel_r": 0.0,
                       "cur_l": -1.0, "cur_r": 2.0})
    run = Run("r", "test", None, {"imu": imu, "wheels": wh})
    obs = measured_observations(run, 0.2, rate)
    calls = list(obs)
    assert calls
    got_imu = np.concatenate([c.imu[:, 1] for c in calls])
    got_wh = np.concatenate([c.wheels[:, 1] for c in calls]) * 0.2
    for got, n, name in ((got_imu, len(t_imu), "imu"), (got_wh, len(t_wh), "wheels")):
        first = obs.dropped_before_start[name]
        assert first + got.size + obs.dropped_after_end[name] == n
        np.testing.assert_allclose(got, np.arange(first, first + got.size))
    prev = -math.inf
    for c in calls:
        for rows in (c.imu, c.wheels, c.currents, c.imu_full):
            assert np.all(rows[:, 0] <= c.t_s) and np.all(rows[:, 0] > prev)
        assert np.all(c.currents[:, 1:] >= 0.0)
        prev = c.t_s


# --- bad input: typed errors naming the argument ------------------------------------------

@pytest.mark.parametrize("shape", [(0,), (1, 1)])
def test_a_state_of_no_drive_unit_or_not_one_dimensional_is_a_shape_error(shape):
    """Before: ``TractionState.zeros(0)`` stopped on a bare IndexError ('index 0 is out of
    bounds'), a state of shape (1, 1) on a bare TypeError ('must be real number, not
    list'); :class:`TractionController` refuses 0 units already."""
    z, no = np.zeros(shape), np.zeros(shape, dtype=bool)
    state = TractionState(z, z, no, z, z, no)
    with pytest.raises(ShapeError, match=r"one entry per drive unit.*" + re.escape(str(shape))):
        traction_control_step(TractionControlConfig(), state, SlipTargets(0.1, -0.1, 0.0),
                              z, z, z, z, 1.0, 0.01)


@pytest.mark.parametrize("targets", [(0.1, -0.15, 0.0), None, 0.1, "ICE"])
def test_targets_that_are_not_a_targets_record_are_a_config_error_naming_them(targets):
    """Before: a plain tuple ``(traction, braking, steady)`` (SlipTargets unpacks as one)
    stopped on a bare AttributeError ''tuple' object has no attribute 'traction''."""
    one_ = np.ones(1)
    with pytest.raises(ConfigError, match="targets must be a SlipTargets"):
        traction_control_step(TractionControlConfig(), TractionState.zeros(1), targets,
                              one_, one_, one_, one_, 1.0, 0.01)


@FAST
@given(st.sampled_from(sorted(TERRAIN_NAMES)), st.floats(0.0, 1.0))
def test_the_acceleration_limit_refuses_a_name_and_reads_an_entry(name, slip):
    """``traction_acceleration_limit("ICE", s)`` stopped on AttributeError ''str' object
    has no attribute 'curve''; now a ConfigError saying to pass ``get_terrain(name)`` (as
    :func:`desired_slip` does); the entry gives ``g (mu(s) - rho(s))``."""
    with pytest.raises(ConfigError, match="get_terrain"):
        traction_acceleration_limit(name, slip)
    ter = get_terrain(name)
    assert traction_acceleration_limit(ter, slip) == pytest.approx(
        G_M_S2 * float(traction_coefficient(ter.curve, slip)
                       - soil_resistance_coefficient(ter, slip)), rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("stream, column, bad", [("imu", "ax", "a"), ("imu", "t_s", "x"),
                                                 ("wheels", "vel_l", True),
                                                 ("wheels", "cur_r", "2 A")])
def test_a_logged_value_that_is_not_a_number_is_named_with_its_column_and_row(
        stream, column, bad):
    """Before: text stopped on numpy's bare ValueError ('could not convert string to
    float: 'a''), naming neither the stream, the column nor the row; a boolean was read
    as 1. Missing values (None) still pass as NaN, which the estimators skip and count."""
    t = [0.0, 0.1, 0.2]
    streams = {"imu": pd.DataFrame({"t_s": t, "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0,
                                    "ay": 0.0, "az": 9.81}),
               "wheels": pd.DataFrame({"t_s": t, "vel_l": 1.0, "vel_r": 1.0, "cur_l": 1.0,
                                       "cur_r": 1.0})}
    ok = Run("r", "test", None, {k: v.copy() for k, v in streams.items()})
    ok.streams["imu"]["ax"] = pd.Series([0.0, None, 1.0], dtype=object)
    assert len(list(measured_observations(ok, 0.2, 10.0))) == 3
    frame = streams[stream]
    frame[column] = pd.Series([*frame[column][:2], bad], dtype=object)
    with pytest.raises(NonNumericError) as info:
        measured_observations(Run("r", "test", None, streams, source="run.csv"), 0.2, 10.0)
    assert (info.value.column, info.value.row, info.value.path) == (column, 2, "run.csv")


# --- the grid's comparison against a per-cell brute force ---------------------------------

def _maybe(lo, hi):
    return st.one_of(st.none(), st.floats(lo, hi))


run_metrics = st.fixed_dictionaries({
    "peak_slip": st.floats(0.01, 1.0), "energy_j_per_m": _maybe(1.0, 500.0),
    "time_to_speed_s": _maybe(0.1, 20.0), "slip_rmse": _maybe(0.0, 1.0),
    "steady_slip_within_0_02": _maybe(0.0, 1.0), "mean_speed_m_s": st.floats(0.0, 2.0),
    "terrain_accuracy": st.floats(0.0, 1.0)})


def _mean(xs):
    xs = [x for x in xs if x is not None]
    return sum(xs) / len(xs) if xs else math.nan


def _same(got, want):
    if want is None or math.isnan(want):
        assert got is None or math.isnan(float(got)), (got, want)
    else:
        assert float(got) == pytest.approx(want, rel=1e-9)


@pytest.mark.slow
@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["ICE", "SNOW"]), st.integers(0, 4), run_metrics,
                          run_metrics), min_size=1, max_size=8,
                unique_by=lambda r: (r[0], r[1])))
def test_compare_equals_a_per_cell_brute_force(cells):
    """:func:`compare` per (vehicle, terrain, scenario) against plain Python over the seeds:
    means over the runs that have a value (None left out and counted), the cuts and the
    time increase paired over the seeds where both runs have one, whatever is missing."""
    rows = [{"vehicle": "husky", "terrain": ter, "scenario": "straight_accel", "seed": seed,
             "controller": ctrl, **m}
            for ter, seed, off, on in cells for ctrl, m in (("off", off), ("traction", on))]
    out = compare(pd.DataFrame(rows)).set_index("terrain")
    for ter in {c[0] for c in cells}:
        mine = [(c[2], c[3]) for c in cells if c[0] == ter]
        r = out.loc[ter]
        offs, ons = [o for o, _ in mine], [n for _, n in mine]
        _same(r["runs"], len(mine))
        _same(r["peak_slip_cut"], 1 - _mean([n["peak_slip"] for n in ons])
              / _mean([o["peak_slip"] for o in offs]))
        for key, short in (("peak_slip", "peak_slip"), ("energy_j_per_m", "energy"),
                           ("slip_rmse", "slip_rmse"), ("time_to_speed_s", "time_to_speed"),
                           ("mean_speed_m_s", "mean_speed")):
            _same(r[f"{short}_off"], _mean([o[key] for o in offs]))
            _same(r[f"{short}_on"], _mean([n[key] for n in ons]))
        for key, short in (("energy_j_per_m", "energy_runs"), ("slip_rmse", "slip_rmse_runs"),
                           ("time_to_speed_s", "time_to_speed_reached")):
            _same(r[f"{short}_off"], sum(o[key] is not None for o in offs))
            _same(r[f"{short}_on"], sum(n[key] is not None for n in ons))
        for key, col, ratio in (("energy_j_per_m", "energy_cut", lambda a, b: 1 - b / a),
                                ("time_to_speed_s", "time_increase", lambda a, b: b / a - 1)):
            pairs = [(o[key], n[key]) for o, n in mine
                     if o[key] is not None and n[key] is not None]
            _same(r[col], ratio(_mean([a for a, _ in pairs]), _mean([b for _, b in pairs]))
                  if pairs else math.nan)
        _same(r["steady_within_0_02_on"], _mean([n["steady_slip_within_0_02"] for n in ons]))
        _same(r["steady_within_0_02_runs_on"],
              sum(n["steady_slip_within_0_02"] is not None for n in ons))
        _same(r["terrain_accuracy_on"], _mean([n["terrain_accuracy"] for n in ons]))


# --- the closed loop on the simulator -----------------------------------------------------

@pytest.mark.slow
@settings(max_examples=6, deadline=None)
@given(st.sampled_from(["husky", "agrimaro"]), st.sampled_from(sorted(TERRAIN_NAMES)),
       st.sampled_from(["straight_accel", "slope_turn"]), st.booleans(), st.integers(0, 50))
def test_closed_loop_energies_shares_and_commands_are_physical(vehicle, terrain, scenario, on,
                                                               seed):
    """Any catalogued terrain, vehicle, scenario and seed (1 s, controller on or in shadow
    mode): the mechanical energy the motors deliver never exceeds what the drive passes to
    them (efficiency <= 1), the energies are >= 0, the shares lie in [0, 1], the true peak
    slip is a slip (<= 1), and every command the loop applied is within the wheel speed
    limit (or the low level's own beyond it) and on the low-level command's side of zero."""
    sim, loop, m = run_closed_loop(vehicle, terrain, scenario, on, seed, duration_s=1.0)
    if m["energy_j_per_m"] is not None:
        assert 0.0 <= m["mech_energy_j_per_m"] <= m["drive_energy_j_per_m"] + 1e-9
        assert m["energy_j_per_m"] >= 0.0
    for key in ("enabled_fraction", "safe_fraction", "terrain_accuracy"):
        assert 0.0 <= m[key] <= 1.0
    assert m["distance_m"] >= 0.0 and 0.0 <= m["peak_slip"] <= 1.0 + 1e-12
    w_max = loop.controller.config.omega_max_rad_s
    for r in loop.log:
        low = np.asarray(r["omega_low_level"], dtype=float)
        cmd = low + (r["correction"] if on else 0.0)
        assert np.all(np.abs(cmd) <= np.maximum(w_max, np.abs(low)) + 1e-9)
        assert np.all(cmd * low >= 0.0)


# --- the slip table's JSON round trip -----------------------------------------------------

def test_the_slip_table_json_rebuilds_the_same_table(capsys):
    """``terrain slip-table --json``: its config rebuilds the rules' settings exactly, every
    row reads back as a valid :class:`DesiredSlip` with the library's exact values (JSON
    keeps the floats), UNKNOWN last, and the table built from the printed config and
    classes is the one printed."""
    from terrain.cli import main
    from terrain.control.desired_slip import (FALLBACK_LABEL, DesiredSlip, DesiredSlipConfig,
                                              build_slip_table)
    assert main(["slip-table", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    config = DesiredSlipConfig(**data["config"])
    assert config == DesiredSlipConfig()
    rows = [DesiredSlip(r["terrain"], r["target_slip_traction"], r["target_slip_braking"],
                        r["target_slip_steady"], r["source"], r["method"])
            for r in data["rows"]]
    assert rows[-1].terrain == FALLBACK_LABEL
    table = build_slip_table([r.terrain for r in rows[:-1]], config)
    assert [*table.entries.values(), table.fallback] == rows


@pytest.mark.parametrize("kwargs, named", [
    ({"speed_slope_s": math.inf}, "speed_slope_s"), ({"accel_block_s": math.inf}, "accel_block_s"),
    ({"speed_slope_s": math.nan}, "speed_slope_s"), ({"accel_block_s": -0.1}, "accel_block_s"),
    ({"adapt_blocks": 2.7}, "adapt_blocks"), ({"adapt_blocks": True}, "adapt_blocks"),
    ({"adapt_blocks": 1}, "adapt_blocks")])
def test_agrimaro_ekf_settings_that_are_not_usable_are_refused_by_name(kwargs, named):
    """Before: an infinite ``speed_slope_s`` (a speed window that keeps the whole run) and
    an infinite ``accel_block_s`` (a block that never closes: the ``full-averaged`` view
    never read its accelerometer) were accepted, and ``adapt_blocks`` 2.7 was read as 2."""
    from terrain.control.estimators import AgriMaRoVisualOdometryEKF
    with pytest.raises(ConfigError, match=named):
        AgriMaRoVisualOdometryEKF(**kwargs)
    assert AgriMaRoVisualOdometryEKF(accel_block_s=0.05, adapt_blocks=2,
                                     speed_slope_s=1.0).speed_slope_s == 1.0
