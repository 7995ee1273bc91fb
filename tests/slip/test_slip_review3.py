"""Third review of the slip area (slip3): turning factor of dead reckoning, mutants of the
physics slip, the SAE conventions and the evaluation tables."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.slip.odometry import dead_reckon
from terrain.vehicles import HUSKY


@pytest.mark.parametrize("chi", [0.0, -2.0, np.array([1.0, 1.0, 0.0, 1.0, 1.0])])
def test_dead_reckon_refuses_a_turning_factor_that_is_not_positive(chi):
    # chi divides the wheels' yaw rate: 0 made the pose NaN from that sample on (a divide
    # warning only), a negative one turned the robot the other way without a word
    t = np.arange(5) * 0.1
    with pytest.raises(ConfigError, match="chi"):
        dead_reckon(t, np.full(5, 0.9), np.full(5, 1.1), HUSKY.track_m, chi=chi)


def test_dead_reckon_ignores_chi_when_the_gyro_gives_the_heading():
    # with the gyro's yaw rate chi is not used, so it is not checked either
    t = np.arange(5) * 0.1
    pose = dead_reckon(t, np.ones(5), np.ones(5), HUSKY.track_m, chi=0.0,
                       yaw_rate_rad_s=np.zeros(5))
    assert np.allclose(pose[:, 0], t) and np.allclose(pose[:, 1:], 0.0)


@pytest.mark.parametrize("track", [0.0, -0.5, np.nan, np.inf, True])
def test_endo_turning_slip_refuses_a_track_that_is_not_a_positive_number(track):
    # B yaw_rate closes eq. 27: a negative track gave other slips (alpha_r 0.22 against 0.12
    # at B = 0.5 m for vl 1, vr 1.5 m/s, yaw rate 0.3 rad/s), 0 dropped the measured turn
    # (0.17), NaN made every slip NaN, all without a word
    from terrain.slip.baselines import endo_turning_slip
    with pytest.raises(ConfigError, match="track_m"):
        endo_turning_slip(np.array([1.0]), np.array([1.5]), np.array([0.3]), track)


def test_observer_window_of_one_imu_sample_is_that_sample():
    # a window holding a single IMU sample: its mean is that sample's observer slip (the
    # count divides the sum; a floor of 2 halved it)
    import pandas as pd

    from terrain.run import Run
    from terrain.slip.baselines import observer_slip, slip_ratio_as_sae
    from terrain.slip.evaluation import observer_window_slip
    t = np.arange(0.0, 4.0, 0.1)
    wz = np.where(t < 1.0, 0.0, 0.6)
    vl, vr = np.full_like(t, 0.4), np.full_like(t, 0.7)
    run = Run("sim/X/orchard/0", "sim", "ASPHALT",
              {"imu": pd.DataFrame({"t_s": t, "wz": wz}),
               "wheels": pd.DataFrame({"t_s": t, "vel_l": vl, "vel_r": vr})})
    meta = pd.DataFrame({"run_id": [run.run_id] * 2, "t_start_s": t[[12, 30]],
                         "t_end_s": t[[13, 31]]})
    out = observer_window_slip([run], meta, HUSKY.track_m)
    yaw = np.concatenate([[0.0], np.cumsum(np.diff(t) * wz[:-1])])
    s = slip_ratio_as_sae(np.column_stack([vl, vr]),
                          observer_slip(t, yaw, vl, vr, 0.5 * HUSKY.track_m))
    assert np.abs(s[[12, 30]]).min() > 1e-3          # a halved mean would show
    np.testing.assert_allclose(out, s[[12, 30]], rtol=1e-12, atol=1e-15)


def _lag_test_signals():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 30.0, 0.01)
    steps = np.repeat(rng.normal(0.0, 1.0, 30), 100)
    ref = np.convolve(steps, np.ones(50) / 50, mode="same")
    sig = np.interp(t - 0.2, t, ref) + rng.normal(0.0, 0.02, t.size)
    return t, ref, sig


def test_lag_gate_refuses_a_peak_just_below_min_correlation_and_takes_one_just_above():
    from terrain.slip.alignment import LagGate, estimate_lag, gated_lag
    t, ref, sig = _lag_test_signals()
    est = estimate_lag(t, ref, t, sig)
    assert 0.05 < est.correlation < 0.95 and not est.at_range_end
    above = LagGate(min_correlation=est.correlation + 0.01, halves_tolerance_s=None)
    below = LagGate(min_correlation=est.correlation - 0.01, halves_tolerance_s=None)
    refused = gated_lag(t, ref, t, sig, gate=above)
    assert not refused.applied and "below" in refused.reason
    assert gated_lag(t, ref, t, sig, gate=below).applied
    assert refused.lag_s == pytest.approx(0.2, abs=0.02)


@pytest.mark.slow
def test_husky_side_slip_with_an_applied_wheel_lag_follows_the_truth():
    # the applied lag moves the wheel samples back by it before the rim speeds are resampled
    # onto the filter's grid: the side slips then follow the truth as on the run without a
    # lag (moved forward instead, the rims were 0.8 s off)
    from terrain.sim import Effects, SimConfig, simulate_with_physics
    from terrain.slip import estimate_run
    from pipelines.validation.harness import simulate_husky, truth_on_grid
    base = simulate_husky("ASPHALT", seed=2, duration_s=30.0, icr_expansion=1.0)
    lagged = simulate_with_physics(SimConfig(**{**base.config.__dict__,
                                                "effects": Effects(wheel_lag=0.4)}))
    est = estimate_run(lagged.run)
    assert est.lag.applied and est.lag.lag_s == pytest.approx(0.4, abs=0.05)
    tr = truth_on_grid(lagged, est.ekf.t_s)
    moving = (np.abs(tr["v_bx"]) > 0.1).to_numpy() & (est.ekf.t_s > 5)
    for j in range(2):
        assert np.nanmedian(np.abs(est.slip[moving, j] - tr[f"slip_{j + 1}"][moving])) < 0.02


def test_wheel_slip_passes_its_dead_band_on():
    # creeping wheel, rim 0.03 m/s over ground 0.02 m/s: inside the thesis's 0.05 m/s dead
    # band the slip is 0 (ch. 7.2.1); without one it is the SAE ratio 1/3 (eq. 7.1)
    from terrain.slip import wheel_slip
    args = (np.array([[0.03]]), np.array([0.02]), np.array([0.0]), np.array([0.0]),
            np.array([[0.0, 0.0]]))
    assert wheel_slip(*args)[0, 0] == 0.0
    assert wheel_slip(*args, dead_band_m_s=0.0)[0, 0] == pytest.approx(1.0 / 3.0)
    assert wheel_slip(*args, dead_band_m_s=0.025)[0, 0] == pytest.approx(1.0 / 3.0)


def test_physics_interval_from_the_rolling_loss_uncertainty_alone():
    # no current noise, no efficiency uncertainty, exact pitch: the traction interval is the
    # rolling-loss part of the traction times its relative std, either side, mapped through
    # the stable side of the curve
    from terrain.slip.physics import (PhysicsSlipSettings, physics_slip,
                                      traction_from_torque, wheel_torque_from_current)
    from terrain.terramechanics.catalogue import get_terrain
    from terrain.terramechanics.inverse import slip_from_traction
    terrain = get_terrain("SANDY_LOAM")
    cur = np.array([[4.0, 5.0], [6.0, 4.5]])
    rim = np.array([[0.8, 0.8], [1.0, 0.9]])
    pitch = np.zeros(2)
    settings = PhysicsSlipSettings(current_std_a=0.0, efficiency_rel_std=0.0,
                                   hysteresis_rel_std=0.15)
    res = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, pitch, settings=settings)
    torque = wheel_torque_from_current(HUSKY.motor, cur,
                                       rim / HUSKY.contact_geometry().wheel_radius_m)
    mu, _, rolling = traction_from_torque(HUSKY, terrain, torque, rim, pitch)
    half = settings.coverage_sigma * np.abs(rolling) * settings.hysteresis_rel_std
    assert half.min() > 0.005 and res.upper.max() < 1.0      # the test can tell
    np.testing.assert_allclose(res.slip, slip_from_traction(terrain.curve, mu).slip)
    np.testing.assert_allclose(res.lower, slip_from_traction(terrain.curve, mu - half).slip)
    np.testing.assert_allclose(res.upper, slip_from_traction(terrain.curve, mu + half).slip)
    off = physics_slip(HUSKY, {"SANDY_LOAM": 1.0}, cur, rim, pitch,
                       settings=PhysicsSlipSettings(current_std_a=0.0, efficiency_rel_std=0.0,
                                                    hysteresis_rel_std=0.0))
    np.testing.assert_allclose(off.std, 0.0, atol=1e-12)


def test_odometry_errors_take_the_truth_in_the_frame_of_its_first_pose():
    # dead reckoning starts at 0 with heading 0; a truth that starts elsewhere (a run cut
    # from a longer one, a mocap frame) was compared in its own frame: straight at 1 m/s for
    # 10 s from (5, 3) heading north scored 139 % with exact wheels
    import pandas as pd

    from terrain.run import Run
    from terrain.slip.evaluation import odometry_errors
    t = np.arange(0.0, 10.0 + 1e-9, 0.05)
    v = np.ones_like(t)
    run = Run("sim/ASPHALT/straight/0", "sim", "ASPHALT",
              {"wheels": pd.DataFrame({"t_s": t, "vel_l": v, "vel_r": v}),
               "truth": pd.DataFrame({"t_s": t, "x": np.full_like(t, 5.0), "y": 3.0 + t,
                                      "yaw": np.full_like(t, 0.5 * np.pi)})})
    meta = pd.DataFrame({"run_id": [run.run_id] * 5, "t_start_s": np.arange(0.0, 10.0, 2.0),
                         "t_end_s": np.arange(2.0, 12.0, 2.0)})
    pred = np.column_stack([np.zeros(5), np.zeros(5), np.ones(5), np.zeros(5)])
    row = odometry_errors([run], meta, pred, HUSKY.track_m, [run.run_id]).iloc[0]
    assert row["distance_m"] == pytest.approx(10.0)
    assert row["plain_err_pct"] == pytest.approx(0.0, abs=1e-9)
    assert row["compensated_err_pct"] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("source", ["physics", "learned", "fused"])
def test_pseudo_measurement_without_a_physics_output_names_it(source):
    # every source reads the physics window outputs (its slip, or the fallback and the
    # heuristic learned std); without them the answer was a bare KeyError: 'physics'
    from terrain.slip import pseudo_measurement
    t = np.arange(3.0)
    learned = (t, np.zeros((3, 2)), np.full((3, 2), 0.01))
    with pytest.raises(ConfigError, match="physics"):
        pseudo_measurement({"learned": learned}, source)
