"""Property-based invariants of the traction PID (seed 001 ch. 8.3.2) and the desired-slip
table (ch. 8.2), over any input sequence hypothesis draws."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.control.desired_slip import (FALLBACK_LABEL, DesiredSlipConfig, build_slip_table,
                                          select_target)
from terrain.control.feedforward import feedforward_step
from terrain.control.traction import (BRAKING, TRACTION, SlipTargets, TractionControlConfig,
                                      TractionController, TractionState, traction_control_step)
from terrain.terramechanics.catalogue import TERRAIN_NAMES

FAST = settings(max_examples=60, deadline=None)

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
speed = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)
omega_s = st.floats(-25.0, 25.0, allow_nan=False, allow_infinity=False)
accel = st.floats(-5.0, 5.0, allow_nan=False, allow_infinity=False)
slip_s = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
gain = st.floats(0.0, 50.0, allow_nan=False, allow_infinity=False)

configs = st.builds(
    TractionControlConfig, kp=gain, ki=gain, kd=st.floats(0.0, 2.0), wheel_radius_m=st.floats(
        0.05, 1.0), omega_max_rad_s=st.floats(1.0, 30.0), output_fraction=st.floats(0.05, 1.0),
    derivative_tau_s=st.floats(0.005, 0.5), release_tau_s=st.floats(0.01, 1.0),
    one_sided=st.booleans())
targets_s = st.builds(SlipTargets, traction=st.floats(0.01, 1.0),
                      braking=st.floats(-1.0, -0.01), steady=st.floats(0.0, 1.0))
#: one step's inputs for one unit: (omega_ll, omega_meas, v_long, a_local, chassis, dt, slip)
step_inputs = st.tuples(omega_s, omega_s, speed, accel, st.floats(0.0, 3.0),
                        st.floats(1e-4, 0.2), st.one_of(st.none(), slip_s))


def _run(cfg, targets, seq, n=1, state=None):
    """Step a one-unit controller through ``seq``; the outputs and the final state."""
    state = TractionState.zeros(n) if state is None else state
    outs = []
    for ll, wm, v, a, ch, dt, sl in seq:
        out, state = traction_control_step(
            cfg, state, targets, np.array([ll]), np.array([wm]), np.array([v]), np.array([a]),
            ch, dt, slip=None if sl is None else np.array([sl]))
        outs.append(out)
    return outs, state


@FAST
@given(configs, targets_s, st.lists(step_inputs, min_size=1, max_size=40))
def test_command_stays_within_the_actuator_limits_for_any_input_sequence(cfg, targets, seq):
    """|omega_cmd| <= omega_max, the command never crosses zero (nor moves a wheel the low
    level holds still), |PID_out| <= output_fraction omega_max where the low-level command is
    within omega_max, and with one_sided the correction is on the limiter's side."""
    limit = cfg.output_fraction * cfg.omega_max_rad_s
    outs, state = _run(cfg, targets, seq)
    for (ll, _, v, a, _, _, _), out in zip(seq, outs):
        cmd, corr = out.omega_cmd_rad_s[0], out.correction_rad_s[0]
        assert abs(cmd) <= cfg.omega_max_rad_s + 1e-12
        assert cmd * ll >= 0.0 and (ll != 0.0 or cmd == 0.0)
        assert cmd == pytest.approx(ll + corr, abs=1e-9)
        if abs(ll) <= cfg.omega_max_rad_s:
            assert abs(corr) <= limit + 1e-9
        if cfg.one_sided and abs(ll) <= cfg.omega_max_rad_s and out.enabled[0]:
            # towards the ground speed: never faster than commanded, except a braking wheel
            # sped up the way the ground moves
            if out.mode[0] == BRAKING and ll * v >= 0.0:
                assert corr * ll >= -1e-12
            else:
                assert corr * ll <= 1e-12
        assert math.isfinite(cmd) and math.isfinite(state.integral[0])


@FAST
@given(configs, targets_s, st.lists(step_inputs, min_size=1, max_size=40))
def test_integral_stays_within_the_room_of_the_output(cfg, targets, seq):
    """Anti-windup: whatever the history, |integral| <= the output limit (it never holds more
    than the output could apply) for a low-level command within omega_max."""
    limit = cfg.output_fraction * cfg.omega_max_rad_s
    state = TractionState.zeros(1)
    for ll, wm, v, a, ch, dt, sl in seq:
        ll = min(max(ll, -cfg.omega_max_rad_s), cfg.omega_max_rad_s)
        _, state = traction_control_step(
            cfg, state, targets, np.array([ll]), np.array([wm]), np.array([v]), np.array([a]),
            ch, dt, slip=None if sl is None else np.array([sl]))
        assert abs(state.integral[0]) <= limit + 1e-9


@pytest.mark.slow
@FAST
@given(st.floats(10.0, 100.0), st.floats(1.0, 50.0), st.integers(50, 2000),
       st.floats(0.05, 0.3), st.booleans())
def test_output_leaves_saturation_at_once_after_a_long_saturation(kp, ki, n_sat, excess,
                                                                  one_sided):
    """Anti-windup: after ``n_sat`` saturated steps of a slip above the target, the output
    leaves saturation within one step of the error changing sign (the integral never holds
    more than the room), and the integral stays bounded by the output limit."""
    cfg = TractionControlConfig(kp=kp, ki=ki, kd=0.0, wheel_radius_m=0.2, omega_max_rad_s=20.0,
                                output_fraction=0.02, one_sided=one_sided)
    limit = cfg.output_fraction * cfg.omega_max_rad_s
    targets = SlipTargets(0.1, -0.15, 0.05)
    ll = np.array([10.0])
    state = TractionState.zeros(1)
    args = (ll, ll, np.array([1.0]), np.array([1.0]), 1.0, 0.01)   # traction, v 1 m/s
    for _ in range(n_sat):
        out, state = traction_control_step(cfg, state, targets, *args,
                                           slip=np.array([0.1 + excess]))
    assert out.correction_rad_s[0] == pytest.approx(-limit)
    assert abs(state.integral[0]) <= limit + 1e-12
    # the slip falls below the target: the error changes sign
    steps = 0
    while True:
        out, state = traction_control_step(cfg, state, targets, *args,
                                           slip=np.array([0.1 - excess]))
        steps += 1
        if out.correction_rad_s[0] > -limit + 1e-9 or steps > 3:
            break
    assert steps <= 1, (steps, out.correction_rad_s[0])


@FAST
@given(configs, targets_s, st.floats(0.1, 3.0), st.floats(-5.0, 5.0), st.floats(1e-3, 0.2),
       st.booleans())
def test_zero_error_from_zero_state_gives_zero_output(cfg, targets, v, a, dt, backwards):
    """A measured slip equal to the desired slip (e = 0 in eq. 8.1), from the zero state,
    gives PID_out = 0 and omega_cmd = omega_low_level (eq. 8.3)."""
    v = -v if backwards else v
    # a low-level command within the wheel speed limit (beyond it the clip is a correction)
    w = min(abs(v) / cfg.wheel_radius_m, cfg.omega_max_rad_s)
    ll = np.array([math.copysign(w, v)])
    # the desired slip the step will pick: run once to read it, then measure exactly that
    out, _ = traction_control_step(cfg, TractionState.zeros(1), targets, ll, ll, np.array([v]),
                                   np.array([a]), abs(v), dt, slip=np.array([0.0]))
    desired = out.desired_slip[0]
    out, state = traction_control_step(cfg, TractionState.zeros(1), targets, ll, ll,
                                       np.array([v]), np.array([a]), abs(v), dt,
                                       slip=np.array([desired]))
    assert out.error[0] == 0.0
    assert out.correction_rad_s[0] == 0.0 and out.omega_cmd_rad_s[0] == ll[0]
    assert state.integral[0] == 0.0


@FAST
@given(configs, targets_s, st.lists(st.tuples(step_inputs, step_inputs), min_size=1,
                                    max_size=25))
def test_controller_is_deterministic_causal_and_per_unit(cfg, targets, pairs):
    """Same inputs -> same outputs; the stateful wrapper equals the pure step threaded by hand;
    two units stepped together equal each unit stepped alone (no coupling between wheels);
    an output never depends on a later input (causal)."""
    seq_a = [p[0] for p in pairs]
    seq_b = [p[1] for p in pairs]
    outs_a, st_a = _run(cfg, targets, seq_a)
    outs_a2, _ = _run(cfg, targets, seq_a)
    outs_b, _ = _run(cfg, targets, seq_b)
    for o1, o2 in zip(outs_a, outs_a2):
        for f1, f2 in zip(o1, o2):
            np.testing.assert_array_equal(f1, f2)
    ctrl = TractionController(cfg, 2)
    for k, (pa, pb) in enumerate(zip(seq_a, seq_b)):
        slips = (pa[6], pb[6])
        slip = None if None in slips else np.array(slips)
        if slip is None and slips != (None, None):
            break  # a mixed estimate/encoder pair cannot be passed in one call
        out = ctrl.step(targets, *[np.array([pa[i], pb[i]]) for i in range(4)],
                        pa[4], pa[5], slip=slip)
        if pb[4:6] == pa[4:6]:
            np.testing.assert_array_equal(out.correction_rad_s[:1], outs_a[k].correction_rad_s)
        else:
            break   # unit b ran with unit a's chassis speed and dt from here on
    # causal: a prefix of the sequence gives the same outputs as the whole one did
    half = len(seq_a) // 2
    outs_p, _ = _run(cfg, targets, seq_a[:half])
    for o1, o2 in zip(outs_p, outs_a):
        np.testing.assert_array_equal(o1.omega_cmd_rad_s, o2.omega_cmd_rad_s)
    assert outs_b is not None and st_a is not None


@FAST
@given(configs, targets_s, st.lists(step_inputs, min_size=1, max_size=30))
def test_units_stepped_together_equal_each_unit_alone(cfg, targets, seq):
    """Per-unit independence: the same sequence mirrored onto a second unit (negated speeds
    and acceleration: reversing) steps as the first one mirrored (sgn(v_long) in eqs.
    8.7-8.9; Table 8.1 cases 2A-2D mirror 1A-1D), and stepping both together equals stepping
    each alone."""
    state = TractionState.zeros(2)
    outs_a, _ = _run(cfg, targets, seq)
    mirrored = [(-ll, -wm, -v, -a, ch, dt, None if sl is None else -sl)
                for ll, wm, v, a, ch, dt, sl in seq]
    outs_m, _ = _run(cfg, targets, mirrored)
    for (ll, wm, v, a, ch, dt, sl), out_a, out_m in zip(seq, outs_a, outs_m):
        slip = None if sl is None else np.array([sl, -sl])
        out, state = traction_control_step(cfg, state, targets, np.array([ll, -ll]),
                                           np.array([wm, -wm]), np.array([v, -v]),
                                           np.array([a, -a]), ch, dt, slip=slip)
        assert out.correction_rad_s[0] == out_a.correction_rad_s[0]
        assert out.correction_rad_s[1] == out_m.correction_rad_s[0]
        assert out.correction_rad_s[1] == pytest.approx(-out.correction_rad_s[0], abs=1e-9)
        assert out.mode[0] == out.mode[1]


@FAST
@given(configs, targets_s, st.lists(step_inputs, min_size=2, max_size=30),
       st.integers(1, 29))
def test_resuming_from_the_returned_state_equals_one_run(cfg, targets, seq, cut):
    """Chunked calls equal one run: stepping a sequence in two chunks, the second starting
    from the first's returned state, gives the same outputs as stepping it at once."""
    cut = min(cut, len(seq) - 1)
    outs, final = _run(cfg, targets, seq)
    outs1, mid = _run(cfg, targets, seq[:cut])
    outs2, final2 = _run(cfg, targets, seq[cut:], state=mid)
    for o1, o2 in zip(outs, outs1 + outs2):
        np.testing.assert_array_equal(o1.omega_cmd_rad_s, o2.omega_cmd_rad_s)
    for f1, f2 in zip(final, final2):
        np.testing.assert_array_equal(f1, f2)


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(st.lists(st.sampled_from(sorted(TERRAIN_NAMES)), min_size=1, max_size=6, unique=True),
       st.floats(0.5, 0.99), st.floats(0.0, 0.04), st.floats(0.05, 0.95),
       st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(0.0, 10.0))
def test_selected_target_is_bounded_monotone_in_confidence_and_conservative_below(
        classes, frac, extra, cap, min_conf, conf, age):
    """Every target lies within the SAE slip's range with traction > 0 > braking and
    0 <= steady <= traction; the fallback is no larger in magnitude than any entry; a
    decision is used iff its confidence is >= min_confidence (monotone: raising the confidence
    never moves back to the fallback) and its age within max_decision_age_s."""
    cfg = DesiredSlipConfig(traction_fraction=frac, braking_fraction=min(frac + extra, 0.999),
                            deformable_cap=cap, min_confidence=min_conf)
    table = build_slip_table(classes, cfg)
    rows = [*table.entries.values(), table.fallback]
    for e in rows:
        assert 0.0 < e.traction <= 1.0 and -1.0 <= e.braking < 0.0
        assert 0.0 <= e.steady <= e.traction
    fb = table.fallback
    assert fb.terrain == FALLBACK_LABEL
    for e in table.entries.values():
        assert fb.traction <= e.traction and abs(fb.braking) <= abs(e.braking)
        assert fb.steady <= e.steady
    label = classes[0]
    got = select_target(table, label.lower(), conf, age)
    fresh = age <= cfg.max_decision_age_s
    assert (got is table.entries[label]) == (conf >= min_conf and fresh)
    if got is table.entries[label]:
        for higher in (conf, (conf + 1.0) / 2, 1.0):
            assert select_target(table, label, higher, age) is got
    else:
        assert got is fb
    assert select_target(table, "NOT-A-CLASS", 1.0, 0.0) is fb


@FAST
@given(targets_s, st.floats(0.05, 3.0), st.floats(0.1, 5.0), st.booleans())
def test_desired_slip_sign_follows_mode_and_direction(targets, v, a, backwards):
    """Traction target >= 0 >= braking target, signed by sgn(v_long) (eqs. 8.7-8.9), in
    slip units (dimensionless, |desired| <= 1)."""
    cfg = TractionControlConfig(one_sided=False)
    v = -v if backwards else v
    sign = -1.0 if backwards else 1.0
    one = (lambda x: np.array([x]))  # noqa: E731
    for acc, mode, target in ((a * sign, TRACTION, targets.traction),
                              (-a * sign, BRAKING, targets.braking)):
        if abs(acc * v) <= cfg.power_threshold_m2_s3:
            continue
        out, _ = traction_control_step(cfg, TractionState.zeros(1), targets, one(v), one(v),
                                       one(v), one(acc), abs(v), 0.01)
        assert out.mode[0] == mode
        assert out.desired_slip[0] == sign * target
        assert abs(out.desired_slip[0]) <= 1.0
    assert targets.traction >= 0.0 >= targets.braking


@settings(max_examples=20, deadline=None)
@given(st.sampled_from(sorted(TERRAIN_NAMES)), st.floats(0.5, 0.98), st.floats(0.0, 0.3),
       st.floats(0.05, 0.9), st.floats(0.0, 0.09))
def test_targets_grow_with_the_peak_fraction_and_the_cap(name, frac, more, cap, more_cap):
    """A larger fraction of the friction peak (on its stable, rising side) or a larger cap on
    deformable soils never gives a smaller target magnitude (the targets are monotone in the
    settings that move them towards the peak)."""
    lo_frac, hi_frac = frac, min(frac + more, 0.99)
    lo = build_slip_table([name], DesiredSlipConfig(lo_frac, lo_frac, cap)).entries[name]
    hi = build_slip_table([name], DesiredSlipConfig(hi_frac, hi_frac, min(cap + more_cap,
                                                                          0.99))).entries[name]
    assert hi.traction >= lo.traction - 1e-12
    assert abs(hi.braking) >= abs(lo.braking) - 1e-12


@FAST
@given(configs, targets_s, st.lists(step_inputs, min_size=1, max_size=10),
       st.sampled_from(["omega", "v", "a", "slip", "chassis", "dt", "age"]),
       st.sampled_from([math.nan, math.inf, -math.inf]))
def test_non_finite_input_gives_the_safe_output_and_clears_the_memory(
        cfg, targets, seq, which, bad):
    """A non-finite measurement, estimate, interval or input age gives omega_cmd =
    omega_low_level (clipped to +-omega_max), flags ``safe`` and zeroes the integral."""
    _, state = _run(cfg, targets, seq)
    ll = 0.5 * cfg.omega_max_rad_s
    inputs = {"omega": ll, "v": 0.3, "a": 0.5, "slip": 0.2, "chassis": 0.3, "dt": 0.01,
              "age": 0.0}
    if which == "chassis" and bad < 0:
        bad = math.nan   # a negative chassis speed is refused, not made safe
    inputs[which] = bad
    out, new = traction_control_step(
        cfg, state, targets, np.array([ll]), np.array([inputs["omega"]]),
        np.array([inputs["v"]]), np.array([inputs["a"]]), inputs["chassis"], inputs["dt"],
        input_age_s=inputs["age"], slip=np.array([inputs["slip"]]))
    assert out.safe[0] and not out.enabled[0]
    assert out.omega_cmd_rad_s[0] == ll and out.correction_rad_s[0] == 0.0
    assert new.integral[0] == 0.0 and new.correction[0] == 0.0 and not new.active[0]


@FAST
@given(st.lists(st.tuples(omega_s, speed, st.floats(0.0, 0.1)), min_size=1, max_size=30),
       st.floats(-2.0, 5.0), st.floats(0.0, 0.9), st.floats(0.05, 1.0))
def test_feedforward_only_lowers_the_wheel_speed_and_its_reference_never_falls_below_zero(
        seq, a_max, s_t, radius):
    """The feed-forward limit only lowers |omega_ll| (never raises it, never crosses zero:
    the command after it is ``sign(omega_ll) omega_lim`` or ``omega_ll``), its reference
    speed stays >= 0, above the rim speed only where the estimate lifts it, and grows by at
    most ``max(a_max, 0) dt`` while engaged; a limited command slips exactly ``s_t`` over the
    reference (``omega_lim = v_ref / (r (1 - s_t))``), and it is deterministic."""
    v_ref, engaged = np.zeros(1), None
    for ll, v_est, dt in seq:
        ff = feedforward_step(v_ref, np.array([v_est]), np.array([ll]), a_max, s_t, radius, dt,
                              engaged)
        again = feedforward_step(v_ref, np.array([v_est]), np.array([ll]), a_max, s_t, radius,
                                 dt, engaged)
        for f1, f2 in zip(ff, again):
            np.testing.assert_array_equal(f1, f2)
        cmd = ll + ff.correction_rad_s[0]
        assert abs(cmd) <= abs(ll) + 1e-12 and cmd * ll >= 0.0
        assert ff.v_ref_m_s[0] >= 0.0
        assert ff.v_ref_m_s[0] <= max(abs(v_est), v_ref[0] + max(a_max, 0.0) * dt) + 1e-12
        assert ff.engaged[0] == (ff.correction_rad_s[0] != 0.0)
        v_est_mag = abs(v_est)
        # the reference never outruns the wheel's own rim speed unless the estimate lifts it
        assert ff.v_ref_m_s[0] <= max(v_est_mag, abs(ll) * radius) + 1e-12
        if engaged is not None and engaged[0]:   # an engaged limit is released at a_max
            assert ff.v_ref_m_s[0] <= v_ref[0] + max(a_max, 0.0) * dt + 1e-12
        if ff.engaged[0]:   # the limited command slips exactly s_t over the reference
            rim = abs(cmd) * radius   # 0: a reference of 0 holds the wheel still
            assert rim - ff.v_ref_m_s[0] == pytest.approx(s_t * rim, abs=1e-9)
        v_ref, engaged = ff.v_ref_m_s, ff.engaged


@FAST
@given(configs, targets_s, st.lists(step_inputs, min_size=1, max_size=20),
       st.lists(step_inputs, min_size=1, max_size=20))
def test_disabled_correction_only_decays(cfg, targets, seq, disabled):
    """Bumpless disable: while the chassis is too slow the held correction only decays in
    magnitude (``release_tau_s``), whatever the measurements, for commands within omega_max."""
    _, state = _run(cfg, targets, seq)
    w = cfg.omega_max_rad_s
    prev = abs(state.correction[0])
    for ll, wm, v, a, _, dt, sl in disabled:
        ll = min(max(ll, -w), w)
        out, state = traction_control_step(
            cfg, state, targets, np.array([ll]), np.array([wm]), np.array([v]), np.array([a]),
            0.0, dt, slip=None if sl is None else np.array([sl]))
        assert not out.enabled[0]
        assert abs(out.correction_rad_s[0]) <= prev + 1e-12
        prev = abs(out.correction_rad_s[0])


@FAST
@given(configs, targets_s, st.lists(step_inputs, min_size=1, max_size=20),
       st.floats(1e-4, 0.2))
def test_enable_with_zero_error_does_not_jump_beyond_the_held_correction(cfg, targets, seq,
                                                                         dt):
    """Bumpless enable: a unit enabled with zero error (kd 0, ki > 0) applies at most the
    correction it held while disabled (the integral starts from it), never a stale integral."""
    _, state = _run(cfg, targets, seq)
    ll = 0.5 * cfg.omega_max_rad_s
    one = (lambda x: np.array([x]))  # noqa: E731
    held, state = traction_control_step(cfg, state, targets, one(ll), one(ll), one(0.5),
                                        one(0.0), 0.0, dt, slip=one(0.0))
    target = targets.traction if cfg.one_sided else targets.steady   # steady: a = 0
    out, _ = traction_control_step(cfg, state, targets, one(ll), one(ll), one(0.5), one(0.0),
                                   1.0, dt, slip=one(target))
    assert out.enabled[0] and out.error[0] == 0.0
    if cfg.ki > 0.0 and cfg.kd == 0.0:
        assert abs(out.correction_rad_s[0]) <= abs(held.correction_rad_s[0]) + 1e-9
