"""Physics slip from drive force: invariants, inverse-curve round trip, planted truth."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError, ShapeError
from terrain.sim.simulate import SimConfig, simulate_with_physics
from terrain.slip.physics import (PhysicsSlipSettings, normal_load_factor, physics_slip,
                                  pitch_from_accelerometer, pitch_std_from_accelerometer,
                                  run_pitch_prior, traction_from_torque,
                                  wheel_torque_from_current)
from terrain.terramechanics.resistance import G_M_S2
from terrain.terramechanics.catalogue import TERRAIN_NAMES, get_terrain
from terrain.terramechanics.inverse import slip_from_traction, stable_side
from terrain.terramechanics.traction import traction_coefficient, traction_peak
from terrain.vehicles import HUSKY
from terrain.vehicles.common import drive_inertia_kg_m2


@pytest.mark.parametrize("name", TERRAIN_NAMES)
def test_inverse_curve_round_trip(name):
    curve = get_terrain(name).curve
    s_grid, _ = stable_side(curve)
    s = np.linspace(-0.98, 0.98, 41) * s_grid[-1]
    back = slip_from_traction(curve, traction_coefficient(curve, s))
    np.testing.assert_allclose(back.slip, s, atol=2e-3)
    assert not back.saturated[np.abs(s) < 0.9 * s_grid[-1]].any()


@pytest.mark.parametrize("name", ["ASPHALT", "ICE", "SNOW"])
def test_inverse_saturates_beyond_the_peak(name):
    curve = get_terrain(name).curve
    peak = traction_peak(curve)
    out = slip_from_traction(curve, np.array([1.5 * peak.mu_max, -1.5 * peak.mu_max]))
    assert out.saturated.all()
    assert out.slip[0] == pytest.approx(-out.slip[1])
    assert abs(out.slip[0]) <= (1.0 if peak.monotonic else peak.slip) + 1e-9


def test_torque_from_current_inverts_the_motor_law():
    torque = np.array([-3.0, 0.0, 2.5, 10.0])
    omega = np.array([-2.0, 3.0, 4.0, 5.0])
    cur = HUSKY.motor.current_from_torque(torque, omega)
    np.testing.assert_allclose(wheel_torque_from_current(HUSKY.motor, cur, omega), torque)


def test_traction_from_torque_with_pitch_uses_smaller_normal_load():
    ter = get_terrain("SANDY_LOAM")
    torque = np.full((2, 2), 5.0)
    rim = np.full((2, 2), 0.5)
    mu, _, rolling = traction_from_torque(HUSKY, ter, torque, rim, np.array([0.0, 0.25]))
    assert mu[1, 0] > mu[0, 0]
    # torque / (r N) = mu + h with N proportional to cos(pitch)
    assert mu[1, 0] + rolling[1, 0] == pytest.approx((mu[0, 0] + rolling[0, 0]) / np.cos(0.25))
    with pytest.raises(ShapeError):
        traction_from_torque(HUSKY, ter, torque[:, :1], rim, np.zeros(2))


def test_zero_drive_on_level_ground_gives_about_zero_slip():
    # the current a coasting, unloaded wheel draws: the no-load current plus the rolling loss
    ter = get_terrain("ASPHALT")
    rim = np.full((1, 2), 0.5)
    _, dmu_dtorque, rolling = traction_from_torque(HUSKY, ter, np.zeros((1, 2)), rim,
                                                   np.zeros(1))
    torque_rolling = rolling / dmu_dtorque
    cur = HUSKY.motor.current_from_torque(torque_rolling, rim / HUSKY.wheel_radius_m)
    out = physics_slip(HUSKY, {"ASPHALT": 1.0}, cur, rim, np.zeros(1))
    np.testing.assert_allclose(out.slip, 0.0, atol=1e-6)
    assert (out.lower <= 0).all() and (out.upper >= 0).all()


@pytest.mark.parametrize("name", ["SANDY_LOAM", "SNOW", "GRASS", "ICE"])
def test_slip_increases_with_current(name):
    cur = np.linspace(1.0, 8.0, 30)[:, None].repeat(2, axis=1)
    out = physics_slip(HUSKY, {name: 1.0}, cur, np.full_like(cur, 0.5), np.zeros(30))
    assert np.all(np.diff(out.slip[:, 0]) >= -1e-12)
    assert out.slip[-1, 0] > out.slip[0, 0]
    assert np.all(out.lower <= out.slip + 1e-12) and np.all(out.upper >= out.slip - 1e-12)


def test_probability_weighting_is_model_averaging():
    cur = np.full((1, 2), 4.0)
    rim = np.full((1, 2), 0.5)
    a = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(1))
    b = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, np.zeros(1))
    mix = physics_slip(HUSKY, {"SANDY_LOAM": 0.5, "SNOW": 0.5}, cur, rim, np.zeros(1))
    np.testing.assert_allclose(mix.slip, 0.5 * (a.slip + b.slip))
    # law of total variance: mean within-terrain variance + spread of the two slips
    spread = 0.25 * (a.slip - b.slip) ** 2
    np.testing.assert_allclose(mix.std ** 2, 0.5 * (a.std ** 2 + b.std ** 2) + spread)
    assert (mix.lower <= np.minimum(a.slip, b.slip)).all()
    assert (mix.upper >= np.maximum(a.slip, b.slip)).all()
    with pytest.raises(ConfigError):
        physics_slip(HUSKY, {"MUD": 1.0}, cur, rim, np.zeros(1))
    with pytest.raises(ConfigError):
        PhysicsSlipSettings(coverage_sigma=0.0)


def test_pitch_from_accelerometer_on_a_slope():
    p = np.radians(15.0)
    g = 9.80665
    assert pitch_from_accelerometer(g * np.sin(p) + 0.3, 0.0, g * np.cos(p), 0.3) == \
        pytest.approx(p)


@pytest.mark.parametrize("name,seed", [("SANDY_LOAM", 7), ("SNOW", 3), ("GRASS", 11)])
def test_planted_truth_on_simulated_straight_runs(name, seed):
    sim = simulate_with_physics(SimConfig(vehicle="husky", terrains=(name,),
                                          scenario="straight_accel", duration_s=15, seed=seed))
    wheels = sim.run.streams["wheels"]
    steady = wheels[wheels["t_s"] > 6.0]
    out = physics_slip(HUSKY, {name: 1.0}, steady[["cur_l", "cur_r"]].to_numpy(),
                       steady[["vel_l", "vel_r"]].to_numpy(), np.zeros(len(steady)))
    truth = sim.run.streams["truth"]
    true_slip = truth.loc[truth["t_s"] > 6.0, "slip_1"].median()
    assert true_slip > 0.05                               # there is slip to find
    assert abs(np.median(out.slip) - true_slip) < 0.01
    inside = (out.lower <= true_slip) & (out.upper >= true_slip)
    assert inside.mean() > 0.8                            # the interval covers the truth


def test_traction_at_the_curve_maximum_opens_the_slip_interval_to_full_spin():
    """Past the peak every slip delivers the maximum traction, so a traction interval that
    reaches it maps to a slip interval reaching +1 (or -1 braking), not the knee slip."""
    from terrain.slip.physics import _slip_interval
    from terrain.terramechanics.inverse import stable_side
    curve = get_terrain("ICE").curve
    mu_max = stable_side(curve)[1][-1]
    lo, hi = _slip_interval(curve, np.array([[0.5 * mu_max, -1.1 * mu_max]]),
                            np.array([[1.1 * mu_max, -0.5 * mu_max]]))
    assert hi[0, 0] == 1.0 and lo[0, 1] == -1.0
    assert 0 < lo[0, 0] < 0.05 and -0.05 < hi[0, 1] < 0


@pytest.mark.parametrize("name", ["SNOW", "SANDY_LOAM", "GRASS", "PLOUGHED"])
def test_traction_above_a_curve_rising_to_full_slip_gives_a_wide_interval(name):
    """Janosi (SNOW, SANDY_LOAM, GRASS) and Brixius (PLOUGHED) curves rise up to full slip:
    no slip lies past their peak, so a traction interval wholly at or above the maximum used
    to map to the single point +-1 (std 0: 161 window-sides of 15 BorealTC SANDY_LOAM / SNOW
    runs). The other end is now the slip at the maximum less the interval's width."""
    from terrain.slip.physics import _slip_interval
    curve = get_terrain(name).curve
    s_grid, mu_grid = stable_side(curve)
    assert s_grid[-1] == 1.0                              # the curve rises up to full slip
    m = mu_grid[-1]
    lo, hi = _slip_interval(curve, np.array([[1.05 * m, -1.25 * m]]),
                            np.array([[1.25 * m, -1.05 * m]]))
    # top of the curve 0.2 m wide: SNOW 0.62, SANDY_LOAM 0.61, GRASS 0.64, PLOUGHED 0.21
    # (before: 1.0 and -1.0, an interval of width 0)
    assert hi[0, 0] == 1.0 and lo[0, 1] == -1.0
    assert 0.1 < lo[0, 0] < 0.8 and -0.8 < hi[0, 1] < -0.1
    np.testing.assert_allclose(traction_coefficient(curve, lo[0, 0]), 0.8 * m, rtol=1e-3)
    # the physics slip of a current far above what the curve can take: full slip, with a
    # wide interval (20 A on level ground at 0.5 m/s: std SNOW 0.36, SANDY_LOAM 0.26, GRASS
    # 0.33, PLOUGHED 0.24; before: 0)
    out = physics_slip(HUSKY, {name: 1.0}, np.full((1, 2), 20.0), np.full((1, 2), 0.5),
                       np.zeros(1))
    assert out.saturated.all()
    np.testing.assert_array_equal(out.slip, 1.0)
    assert np.all(out.std > 0.1) and np.all(out.lower < 0.6) and np.all(out.upper == 1.0)


def test_within_window_spread_counts_only_above_the_sensor_noise():
    from terrain.slip.physics import within_window_current_std
    got = within_window_current_std(np.array([[0.05, 0.08], [0.10, 0.5]]), 0.08, (2, 2))
    np.testing.assert_allclose(got, [[0.0, 0.0], [0.06, np.sqrt(0.25 - 0.0064)]])
    np.testing.assert_array_equal(within_window_current_std(None, 0.08, (3, 2)), 0.0)
    with pytest.raises(ShapeError):
        within_window_current_std(np.zeros((3, 1)), 0.08, (3, 2))
    cur, rim = np.full((2, 2), 4.0), np.full((2, 2), 0.5)
    exact = PhysicsSlipSettings(efficiency_rel_std=0.0, hysteresis_rel_std=0.0)
    steady = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(2), settings=exact)
    moving = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(2), settings=exact,
                          current_within_std_a=np.array([[0.05, 0.05], [2.0, 2.0]]))
    np.testing.assert_allclose(moving.std[0], steady.std[0])
    assert np.all(moving.std[1] > 2 * steady.std[1])
    np.testing.assert_allclose(moving.slip, steady.slip)


def test_an_unknown_within_window_spread_is_not_taken_as_steady():
    # a NaN spread (steadiness unknown) gave 0, a steady window: the physics std of that
    # side was the steady one (0.0061 on SANDY_LOAM at 4 A, efficiency and hysteresis
    # uncertainties off; a 2 A spread gives 0.19) as if the traction held still
    from terrain.slip.physics import within_window_current_std
    got = within_window_current_std(np.array([[np.nan, 0.5]]), 0.08, (1, 2))
    assert np.isnan(got[0, 0]) and got[0, 1] == pytest.approx(np.sqrt(0.25 - 0.0064))
    cur, rim = np.full((1, 2), 4.0), np.full((1, 2), 0.5)
    exact = PhysicsSlipSettings(efficiency_rel_std=0.0, hysteresis_rel_std=0.0)
    steady = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(1), settings=exact)
    unknown = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(1), settings=exact,
                           current_within_std_a=np.array([[np.nan, 0.05]]))
    np.testing.assert_allclose(unknown.slip, steady.slip)
    assert np.isnan(unknown.std[0, 0]) and np.isnan(unknown.lower[0, 0]) \
        and np.isnan(unknown.upper[0, 0])
    assert unknown.std[0, 1] == pytest.approx(steady.std[0, 1])


def test_pitch_std_matches_the_spread_of_window_means_of_coloured_vibration():
    # AR(1) vibration (pole 0.6) of 2 m/s^2 on level ground, 100-sample windows: the std of
    # the window-mean pitch predicted from each window alone against its actual spread
    rng = np.random.default_rng(4)
    n_w, n, a = 4000, 100, 0.6
    w = rng.standard_normal((n_w, n + 200)) * 2.0 * np.sqrt(1 - a * a)
    ax = np.zeros_like(w)
    for k in range(1, w.shape[1]):
        ax[:, k] = a * ax[:, k - 1] + w[:, k]
    ax = ax[:, 200:]
    pitch = pitch_from_accelerometer(ax.mean(axis=1), 0.0, G_M_S2)
    predicted = np.sqrt(np.mean(pitch_std_from_accelerometer(ax) ** 2))
    assert predicted == pytest.approx(pitch.std(), rel=0.08)
    # white noise: tau ~ 1, the plain std of the mean
    white = rng.standard_normal((n_w, n))
    np.testing.assert_allclose(np.median(pitch_std_from_accelerometer(white)),
                               1.0 / np.sqrt(n) / G_M_S2, rtol=0.1)
    assert pitch_std_from_accelerometer(np.ones((2, 50))).tolist() == [0.0, 0.0]


def test_normal_load_factor_makes_the_cosine_unbiased():
    rng = np.random.default_rng(5)
    for p, sigma in ((0.0, 0.06), (0.2, 0.05)):
        est = p + sigma * rng.standard_normal(200_000)
        factor, rel = normal_load_factor(est, np.full_like(est, sigma))
        corrected = np.cos(est) * factor
        assert np.mean(np.cos(est)) < np.cos(p) * (1 - 0.4 * sigma ** 2)   # biased low
        assert np.mean(corrected) == pytest.approx(np.cos(p), rel=2e-4)
        # the reported relative std covers the corrected load's spread: close to it on a
        # slope, up to 1.45x on level ground (tan(p)^2 estimated by a clipped difference)
        ratio = np.sqrt(np.mean(rel ** 2)) / (corrected.std() / np.cos(p))
        assert 0.9 < ratio < (1.15 if p else 1.45)
    f, r = normal_load_factor(np.array([0.1]), None)
    assert f.tolist() == [1.0] and r.tolist() == [0.0]


def test_run_pitch_prior_makes_the_load_std_match_its_spread_on_level_ground_and_slopes():
    # empirical Bayes: the run's pitch mean and its spread beyond the window noise replace
    # the clipped per-window estimate of tan(p)^2, which is 1.4x too wide on level ground
    rng = np.random.default_rng(7)
    sigma = 0.06
    for p in (0.0, 0.2):
        est = p + sigma * rng.standard_normal(200_000)
        sd = np.full_like(est, sigma)
        prior = run_pitch_prior(est, sd)
        assert prior[0] == pytest.approx(p, abs=1e-3) and prior[1] < 1e-5
        factor, rel = normal_load_factor(est, sd, prior)
        spread = (np.cos(est) * factor).std() / np.cos(p)
        assert np.sqrt(np.mean(rel ** 2)) == pytest.approx(spread, rel=0.05)
        # the mean correction does not depend on the prior
        np.testing.assert_array_equal(factor, normal_load_factor(est, sd)[0])
    # a run over varied slopes: the windows follow their own pitch
    true = rng.uniform(-0.3, 0.3, 5000)
    est = true + sigma * rng.standard_normal(true.size)
    prior = run_pitch_prior(est, np.full_like(est, sigma))
    assert prior[1] == pytest.approx(np.var(true), rel=0.1)
    rel = normal_load_factor(est, np.full_like(est, sigma), prior)[1]
    err = np.cos(est) * np.exp(0.5 * sigma ** 2) / np.cos(true) - 1.0
    assert np.sqrt(np.mean(rel ** 2)) == pytest.approx(err.std(), rel=0.1)
    with pytest.raises(ShapeError):
        run_pitch_prior(np.zeros(3), np.zeros(2))
    with pytest.raises(ShapeError):
        run_pitch_prior(np.full(2, np.nan), np.ones(2))


@pytest.mark.slow
def test_noisy_pitch_no_longer_biases_the_physics_slip_on_snow():
    # planted: the exact drive of a steady SNOW window, pitch read with 0.06 rad of noise
    rng = np.random.default_rng(6)
    n = 20_000
    rim = np.full((n, 2), 0.95)
    exact = physics_slip(HUSKY, {"SNOW": 1.0}, np.full((1, 2), 5.2), rim[:1], np.zeros(1))
    pitch = 0.06 * rng.standard_normal(n)
    cur = np.full((n, 2), 5.2)
    plain = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, pitch)
    fixed = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, pitch, pitch_std_rad=np.full(n, 0.06))
    bias_plain = plain.slip.mean() - exact.slip.mean()
    bias_fixed = fixed.slip.mean() - exact.slip.mean()
    assert bias_plain > 5e-4                                  # cos(pitch) < 1: slip read high
    assert abs(bias_fixed) < 0.1 * bias_plain


def test_saturated_follows_each_rows_most_probable_terrain():
    # the terrain was chosen once over all rows (by summed probability): an ICE row asking
    # for more than ice can give read as unsaturated among ASPHALT rows
    cur = np.full((3, 2), 8.0)
    rim = np.full((3, 2), 0.5)
    probs = {"ASPHALT": np.array([1.0, 1.0, 0.0]), "ICE": np.array([0.0, 0.0, 1.0])}
    batch = physics_slip(HUSKY, probs, cur, rim, np.zeros(3))
    alone = physics_slip(HUSKY, {"ICE": 1.0}, cur[2:], rim[2:], np.zeros(1))
    np.testing.assert_array_equal(batch.saturated[2], alone.saturated[0])
    assert alone.saturated[0].all()
    np.testing.assert_array_equal(
        batch.saturated[:2], physics_slip(HUSKY, {"ASPHALT": 1.0}, cur[:2], rim[:2],
                                          np.zeros(2)).saturated)


def test_a_window_without_a_pitch_gets_no_traction():
    # traction_from_torque filled its rows one distinct pitch at a time into np.empty arrays;
    # NaN equals no pitch, so a window whose accelerometer mean is NaN kept uninitialised
    # memory (mu = inf on [0, NaN, 0.05] at 5 N m on GRASS) instead of NaN
    torque = np.full((3, 2), 5.0)
    rim = np.ones((3, 2))
    pitch = np.array([0.0, np.nan, 0.05])
    mu, dmu, rolling = traction_from_torque(HUSKY, get_terrain("GRASS"), torque, rim, pitch)
    for out in (mu, dmu, rolling):
        assert np.isnan(out[1]).all()
        assert np.isfinite(out[[0, 2]]).all()
    ref = traction_from_torque(HUSKY, get_terrain("GRASS"), torque[[0, 2]], rim[[0, 2]],
                               pitch[[0, 2]])[0]
    np.testing.assert_array_equal(mu[[0, 2]], ref)


def test_physics_slip_refuses_inputs_of_another_shape_by_name():
    # a scalar pitch raised numpy's "too many indices for array: array is 0-dimensional"
    # (IndexError); a pitch std, wheel acceleration, sample count or terrain probability of
    # another length "operands could not be broadcast together" (ValueError), though the
    # docstring promises ShapeError for inconsistent shapes
    cur = np.array([[10.0, 11.0], [12.0, 12.0], [8.0, 9.0]])
    rim = np.array([[0.5, 0.5], [0.6, 0.6], [0.4, 0.45]])
    pitch = np.zeros(3)
    for kwargs, name in (({"pitch_rad": 0.0}, "pitch_rad"),
                         ({"pitch_rad": np.zeros(2)}, "pitch_rad"),
                         ({"pitch_std_rad": np.full(2, 0.01)}, "pitch_std_rad"),
                         ({"wheel_accel_rad_s2": np.ones(3)}, "wheel_accel_rad_s2"),
                         ({"n_averaged": np.ones(2)}, "n_averaged"),
                         ({"terrain_probabilities": {"SNOW": np.ones(2)}}, "SNOW")):
        args = {"terrain_probabilities": {"SNOW": 1.0}, "pitch_rad": pitch, **kwargs}
        with pytest.raises(ShapeError, match=name):
            physics_slip(HUSKY, args.pop("terrain_probabilities"), cur, rim,
                         args.pop("pitch_rad"), **args)
    # a sample count of 0, below 0 or NaN gave a NaN std without a word (n_averaged 0: std
    # [nan nan nan]; [13, 0, 13]: [0.047 nan 0.161] on the slip of the left side)
    for bad in (0.0, -4.0, np.nan, np.array([13.0, 0.0, 13.0])):
        with pytest.raises(ConfigError, match="n_averaged"):
            physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, pitch, n_averaged=bad)
    # what the docstring allows still runs: constants, per-row arrays
    physics_slip(HUSKY, {"SNOW": np.ones(3)}, cur, rim, pitch, np.zeros((3, 2)),
                 n_averaged=np.full(3, 13.0), pitch_std_rad=np.full(3, 0.01))


def test_physics_slip_settings_refuse_what_is_not_a_finite_number_in_range():
    # current_std_a NaN gave a NaN std on every window-side without a word (the check
    # 'min(...) < 0' is False for NaN), inf the same; the text '0.1' raised Python's
    # "'<' not supported between instances of 'float' and 'str'"; min_probability 2 dropped
    # every terrain and said "terrain probabilities sum to 0 on some rows"
    for kwargs, match in (({"current_std_a": float("nan")}, "current_std_a"),
                          ({"current_std_a": float("inf")}, "current_std_a"),
                          ({"efficiency_rel_std": float("nan")}, "efficiency_rel_std"),
                          ({"hysteresis_rel_std": -0.1}, "hysteresis_rel_std"),
                          ({"current_std_a": "0.1"}, "current_std_a must be a real number"),
                          ({"coverage_sigma": float("inf")}, "coverage_sigma"),
                          ({"min_probability": 2.0}, "min_probability"),
                          ({"min_probability": float("nan")}, "min_probability")):
        with pytest.raises(ConfigError, match=match):
            PhysicsSlipSettings(**kwargs)
    PhysicsSlipSettings(current_std_a=0.0, efficiency_rel_std=0.0, hysteresis_rel_std=0.0,
                        min_probability=0.0)


def test_reversing_is_the_mirror_image_of_driving_forward():
    """Flat ground, odd traction curves: a side driving backwards at the same current
    magnitude (the logged current is unsigned, its sign comes from the wheel speed) has the
    opposite slip with the same std and a mirrored interval."""
    cur = np.array([[8.0, 12.0]])
    rim = np.array([[0.5, 0.8]])
    fwd = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(1))
    back = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, -rim, np.zeros(1))
    assert np.all(fwd.slip > 0)
    np.testing.assert_allclose(back.slip, -fwd.slip, atol=1e-12)
    np.testing.assert_allclose(back.std, fwd.std, atol=1e-12)
    np.testing.assert_allclose(back.lower, -fwd.upper, atol=1e-12)


def test_wheel_inertia_torque_is_removed_before_the_traction():
    """``mu`` from torque T while the wheel accelerates at alpha equals ``mu`` from the
    torque ``T - J alpha`` of a steady wheel (J: drive inertia at the wheel)."""
    ter = get_terrain("GRASS")
    torque = np.full((1, 2), 6.0)
    rim = np.full((1, 2), 0.5)
    alpha = np.array([[4.0, -4.0]])
    accel = traction_from_torque(HUSKY, ter, torque, rim, np.zeros(1), alpha)[0]
    steady = traction_from_torque(HUSKY, ter, torque - drive_inertia_kg_m2(HUSKY) * alpha,
                                  rim, np.zeros(1))[0]
    assert drive_inertia_kg_m2(HUSKY) > 0
    np.testing.assert_allclose(accel, steady, rtol=1e-12)
    assert accel[0, 0] < accel[0, 1]        # spinning up takes torque away from the ground


def test_interval_is_coverage_sigma_stds_either_side_for_one_terrain():
    """One terrain (no between-terrain spread), slip on the curve's stable side: the
    reported interval is ``[lo, hi]`` and the std ``(hi - lo) / (2 k)``, so its width is
    ``2 k std`` for any coverage ``k``; and the current noise of the mean of n samples
    shrinks as 1 / sqrt(n) (only current noise here: four samples halve the std, to first
    order in the small noise)."""
    cur = np.array([[4.0, 5.0]])
    rim = np.array([[0.5, 0.5]])
    for k in (1.0, 2.0, 3.0):
        ps = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(1),
                          settings=PhysicsSlipSettings(coverage_sigma=k))
        assert np.all((ps.lower > -1) & (ps.upper < 1))
        np.testing.assert_allclose(ps.upper - ps.lower, 2.0 * k * ps.std, rtol=1e-9)
    only_current = PhysicsSlipSettings(current_std_a=0.05, efficiency_rel_std=0.0,
                                       hysteresis_rel_std=0.0)
    one, four = (physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(1),
                              n_averaged=n, settings=only_current).std for n in (1.0, 4.0))
    np.testing.assert_allclose(four, one / 2.0, rtol=2e-2)


def test_terrains_below_the_minimum_probability_are_dropped():
    """A 0.05 % share of ICE is below ``min_probability`` (0.1 %): the slip is SNOW's alone,
    not pulled towards ICE's (whose curve gives another slip for the same current)."""
    cur = np.array([[10.0, 10.0]])
    rim = np.array([[0.5, 0.5]])
    snow = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, np.zeros(1))
    ice = physics_slip(HUSKY, {"ICE": 1.0}, cur, rim, np.zeros(1))
    assert np.all(np.abs(ice.slip - snow.slip) > 1e-3)
    mixed = physics_slip(HUSKY, {"SNOW": 0.9995, "ICE": 0.0005}, cur, rim, np.zeros(1))
    np.testing.assert_array_equal(mixed.slip, snow.slip)
    np.testing.assert_array_equal(mixed.std, snow.std)


def test_a_row_without_any_terrain_at_the_minimum_probability_is_refused_naming_it():
    """Every probability of a row below ``min_probability`` (0.1 %) leaves it no terrain:
    refused naming the row and the floor (the message said "sum to 0" of a row summing to
    0.0006)."""
    cur = np.array([[10.0, 10.0]] * 3)
    rim = np.array([[0.5, 0.5]] * 3)
    with pytest.raises(ConfigError, match=r"1 row\(s\) \(first 2\).*min_probability 0.001"):
        physics_slip(HUSKY, {"ICE": np.array([0.5, 1.0, 0.0006])}, cur, rim, np.zeros(3))


def test_interval_of_a_terrain_mixture_covers_each_terrains_slip():
    """Half GRASS, half SANDY_LOAM: the same current means a different slip on each (4 A:
    0.36 against 0.09); the reported interval (the weighted intervals widened by k times the
    spread between the terrains' slips, law of total variance) holds both."""
    cur = np.array([[4.0, 4.5]])
    rim = np.array([[0.5, 0.5]])
    each = [physics_slip(HUSKY, {name: 1.0}, cur, rim, np.zeros(1)).slip
            for name in ("GRASS", "SANDY_LOAM")]
    mixed = physics_slip(HUSKY, {"GRASS": 0.5, "SANDY_LOAM": 0.5}, cur, rim, np.zeros(1))
    assert np.all(np.abs(each[0] - each[1]) > 0.02)
    assert np.all(mixed.lower <= np.minimum(*each)) and np.all(mixed.upper >= np.maximum(*each))


def test_pitch_from_accelerometer_on_a_slope_driven_across_at_a_roll():
    # body pitched 0.2 rad and rolled 0.3 rad: gravity reads g (sin p, -cos p sin r,
    # cos p cos r); the roll takes part of cos p into a_y, so a_z alone would make the
    # pitch 0.209 rad
    p, r = 0.2, 0.3
    f = G_M_S2 * np.array([np.sin(p), -np.cos(p) * np.sin(r), np.cos(p) * np.cos(r)])
    assert pitch_from_accelerometer(*f) == pytest.approx(p, abs=1e-12)


def test_load_std_with_a_run_prior_is_the_posterior_mean_of_tan_squared():
    # prior N(0, 0.01 rad^2) and window noise sigma 0.1 rad: k = 0.5; at p_hat = 0 the
    # posterior mean of p^2 is (0 + 0.5 * 0)^2 + 0.5 * 0.01 = 0.005, so the relative std is
    # sqrt(0.005 * 0.01 + 0.5 * 0.01^2) = 0.01 (without the posterior variance 0.0071)
    factor, rel = normal_load_factor(np.array([0.0, 0.2]), np.array([0.1, 0.1]), (0.0, 0.01))
    np.testing.assert_allclose(factor, np.exp(0.005))
    np.testing.assert_allclose(rel[0], 0.01, rtol=1e-12)
    tan2 = np.tan(0.1) ** 2 + 0.005                    # p_hat 0.2 shrunk half-way to 0
    np.testing.assert_allclose(rel[1], np.sqrt(tan2 * 0.01 + 0.5e-4), rtol=1e-12)


def test_reported_traction_of_a_terrain_mixture_is_probability_weighted():
    # each terrain's rolling loss gives its own gross traction for one current; the mixture
    # reports their probability-weighted mean (not their sum)
    cur = np.array([[4.0, 6.0], [2.0, 3.0]])
    rim = np.array([[0.5, 0.6], [0.3, 0.4]])
    a = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(2))
    b = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, np.zeros(2))
    assert not np.allclose(a.mu, b.mu)
    mix = physics_slip(HUSKY, {"SANDY_LOAM": 0.3, "SNOW": 0.7}, cur, rim, np.zeros(2))
    np.testing.assert_allclose(mix.mu, 0.3 * a.mu + 0.7 * b.mu, rtol=1e-12)


def test_load_uncertainty_scales_the_whole_torque_share_of_the_traction():
    # a relative normal-load error e changes torque / load, i.e. mu + rolling, by e: with
    # the pitch noise as the only uncertainty the interval is the curve's inverse at
    # mu +- k (mu + rolling) rel_std (the rolling part is 35-58 % of it on SANDY_LOAM here)
    terrain = get_terrain("SANDY_LOAM")
    cur, rim = np.array([[4.0, 6.0]]), np.array([[0.5, 0.6]])
    pitch, pitch_std = np.array([0.05]), np.array([0.08])
    quiet = PhysicsSlipSettings(current_std_a=0.0, efficiency_rel_std=0.0,
                                hysteresis_rel_std=0.0)
    out = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, pitch, settings=quiet,
                       pitch_std_rad=pitch_std)
    torque = wheel_torque_from_current(HUSKY.motor, cur,
                                       rim / HUSKY.contact_geometry().wheel_radius_m)
    mu, _, rolling = traction_from_torque(HUSKY, terrain, torque, rim, pitch,
                                          pitch_std_rad=pitch_std)
    sd = (mu + rolling) * normal_load_factor(pitch, pitch_std)[1][:, None]
    assert np.all(rolling > 0.1 * mu)
    k = quiet.coverage_sigma
    np.testing.assert_allclose(out.lower, slip_from_traction(terrain.curve, mu - k * sd).slip)
    np.testing.assert_allclose(out.upper, slip_from_traction(terrain.curve, mu + k * sd).slip)


def test_a_terrain_of_probability_0_001_or_more_enters_the_average_one_below_does_not():
    # docs/slip_learning.md section 1: the slip is computed under every terrain with
    # probability >= 0.001 and averaged with the probabilities (renormalised over those)
    # (hand mutant: min_probability 0.3, no test failed: the mixtures tested were 50/50)
    cur = np.full((1, 2), 4.0)
    rim = np.full((1, 2), 0.5)
    a = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, np.zeros(1))
    b = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, np.zeros(1))
    assert np.all(np.abs(a.slip - b.slip) > 0.01)
    mix = physics_slip(HUSKY, {"SANDY_LOAM": 0.99, "SNOW": 0.01}, cur, rim, np.zeros(1))
    np.testing.assert_allclose(mix.slip, 0.99 * a.slip + 0.01 * b.slip)
    low = physics_slip(HUSKY, {"SANDY_LOAM": 0.9995, "SNOW": 0.0005}, cur, rim, np.zeros(1))
    np.testing.assert_allclose(low.slip, a.slip)


@pytest.mark.parametrize("terrain", ["ASPHALT", "SANDY_LOAM", "SNOW"])
def test_a_side_at_rest_weighs_both_signs_of_its_current_half(terrain):
    """At rim speed 0 the reported current magnitude has no sign (the wheel holds against
    either direction): the slip is the even mixture of the two signs, the mirror of
    itself, whose spread and interval cover both (a forward sign alone made a reversing
    start differ from the mirrored forward one)."""
    cur = np.array([[2.0, 0.5]])
    eps = 1e-9
    ahead = physics_slip(HUSKY, {terrain: 1.0}, cur, np.full((1, 2), eps), np.zeros(1))
    back = physics_slip(HUSKY, {terrain: 1.0}, cur, np.full((1, 2), -eps), np.zeros(1))
    rest = physics_slip(HUSKY, {terrain: 1.0}, cur, np.zeros((1, 2)), np.zeros(1))
    np.testing.assert_allclose(rest.slip, (ahead.slip + back.slip) / 2, atol=1e-6)
    np.testing.assert_allclose(rest.slip, 0.0, atol=1e-6)      # the two mirror each other
    assert (rest.std >= np.abs(ahead.slip) - 1e-6).all()
    assert (rest.lower <= back.lower + 1e-6).all() and (rest.upper >= ahead.upper - 1e-6).all()
