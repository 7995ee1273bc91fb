"""The inputs of the run estimates: the wheel-stream lag of the slip-augmented EKF (applied
only for a clear peak), full-slip window-sides at their interval centre, the noise tuning
measured on the run, the camera EMA remedy, the rim speeds resampled onto the filter grid
and the count of slips saturated at the clip."""

from __future__ import annotations

import numpy as np
import pytest

from features.slip_outputs import slip_model_outputs
from pipelines.validation.harness import simulate_husky, truth_on_grid
from terrain.sim import Effects, SimConfig, simulate_with_physics
from terrain.slip.estimate import estimate_skid_steer_slip_run


@pytest.mark.slow
def test_slip_augmented_estimate_moves_the_lagged_wheels_back_by_the_applied_lag():
    # wheels planted 0.4 s late: the slip-augmented EKF must take the wheel sample of
    # t + lag (speed RMS 0.022 m/s against 0.124 without the lag; moving the wheel times the
    # other way doubles the misalignment)
    base = simulate_husky("ASPHALT", seed=2, duration_s=30.0, icr_expansion=1.0)
    lagged = simulate_with_physics(SimConfig(**{**base.config.__dict__,
                                                "effects": Effects(wheel_lag=0.4)}))
    out = slip_model_outputs(lagged.run)
    errs = {}
    for mode in ("none", "xcorr"):
        est = estimate_skid_steer_slip_run(lagged.run, "physics", outputs=out, lag=mode)
        tr = truth_on_grid(lagged, est.ekf.t_s)
        moving = (np.abs(tr["v_bx"]) > 0.1).to_numpy() & (est.ekf.t_s > 5)
        e = est.ekf.state("v_bx")[moving] - tr["v_bx"].to_numpy()[moving]
        errs[mode] = float(np.sqrt(np.mean(e ** 2)))
    assert est.lag.applied and est.lag.lag_s == pytest.approx(0.4, abs=0.05)
    # the filter runs at the IMU's rate (100 Hz), not the wheels' 6.5 Hz
    imu_t = lagged.run.streams["imu"]["t_s"].to_numpy()
    assert est.ekf.meta["rate_hz"] == pytest.approx(1.0 / np.median(np.diff(imu_t)))
    assert est.ekf.meta["time_offsets_s"] == {"wheels": est.lag.lag_s}
    assert errs["xcorr"] < 0.4 * errs["none"], errs


@pytest.mark.slow
def test_slip_augmented_estimate_leaves_a_lag_without_a_clear_peak_unapplied(borealtc_runs):
    # SANDY_LOAM/07: whole-run peak at -0.33 s, correlation far below the gate: the estimate
    # must be that of lag="none" (applying it would move the wheels by a third of a second)
    run = next(r for r in borealtc_runs if r.run_id == "borealtc/SANDY_LOAM/07")
    out = slip_model_outputs(run)
    est = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="xcorr")
    assert not est.lag.applied and abs(est.lag.lag_s) > 0.2
    assert est.ekf.meta["time_offsets_s"] == {}
    none = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="none")
    np.testing.assert_array_equal(est.slip, none.slip)
    np.testing.assert_array_equal(est.slip_std, none.slip_std)
    assert any("not applied" in n for n in est.notes)


def test_clip_note_counts_only_ratios_beyond_one():
    from terrain.slip.estimate import clip_notes
    # a locked wheel under a moving robot is -1 exactly (eq. 7.2), not saturated
    assert clip_notes(np.array([[1.0, -1.0], [0.5, -0.2]]), "r") == ()
    note, = clip_notes(np.array([[1.5, -1.0], [-2.0, 1.0], [0.3, 0.0]]), "a/B/0")
    assert note.startswith("note: run a/B/0: 2 of 6 wheel slip samples beyond +-1")


def test_camera_ema_remedy_is_the_theses_alpha_with_raw_encoders():
    from terrain.estimation.agrimaro import AgriMaRoEKFSettings
    from terrain.slip.estimate import with_camera_ema
    ema = dict(with_camera_ema(AgriMaRoEKFSettings()).ema_alpha)
    assert ema["cam"] == 0.2 and ema["omega"] == 0.0        # eq. 7.8, ch. 7.2.2


def test_resample_is_nan_before_the_first_and_after_the_last_sample():
    from terrain.slip.estimate import resample
    t = np.array([1.0, 2.0, 3.0])
    values = np.array([[10.0], [20.0], [30.0]])
    out = resample(np.array([0.5, 1.0, 2.5, 3.0, 3.5]), t, values)
    np.testing.assert_allclose(out[:, 0], [np.nan, 10.0, 25.0, 30.0, np.nan])


def _imu_run(n, std, rate_hz=100.0, seed=0):
    import pandas as pd
    from terrain.run import Run
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate_hz
    imu = pd.DataFrame({"t_s": t, "ax": rng.normal(0.0, std, n), "ay": rng.normal(0.0, std, n)})
    return Run("sim/GRASS/0", "sim", "GRASS", {"imu": imu}, vehicle="agrimaro")


def test_noise_tuning_takes_the_accelerometer_noise_measured_on_the_run():
    from terrain.slip.estimate import agrimaro_settings
    r = agrimaro_settings(_imu_run(2000, 0.3)).r_diag
    assert np.sqrt(r[3]) == pytest.approx(0.3, rel=0.1)      # ax, ay rows (m/s^2)
    assert r[3] == r[4]
    # 50 IMU samples are too few to measure it: the default 0.8 m/s^2
    assert np.sqrt(agrimaro_settings(_imu_run(50, 0.3)).r_diag[3]) == pytest.approx(0.8)
    assert np.sqrt(agrimaro_settings(_imu_run(51, 0.3)).r_diag[3]) < 0.6


@pytest.mark.slow
def test_a_full_slip_window_side_enters_as_the_centre_of_its_physics_interval():
    # every window-side at full slip (+1) with the interval [0.2, 0.4]: the slip the filter
    # settles on is the centre 0.3 (the upper end would read 0.4, the bound +1 itself 1)
    run = simulate_husky("ASPHALT", seed=2, duration_s=20.0, icr_expansion=1.0,
                         scenario="straight_accel").run
    out = dict(slip_model_outputs(run))
    t, slip, std = out["physics"]
    out["physics"] = (t, np.ones_like(slip), np.full_like(std, 0.01))
    out["physics_interval"] = (t, np.full_like(slip, 0.2), np.full_like(slip, 0.4))
    est = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="none")
    assert est.meta["pseudo_full_slip"] == slip.size
    assert est.meta["pseudo_full_slip_use"] == "interval centre"
    late = est.ekf.t_s > 10.0
    np.testing.assert_allclose(np.median(est.slip[late], axis=0), 0.3, atol=0.02)


def test_agrimaro_encoder_lag_compares_speeds_not_velocities_when_reversing():
    """The camera reference is the speed |v_c|; the rim speed must be |omega| r too: a run
    driven backwards (omega < 0) with the encoders 0.3 s late still gives +0.3 s, applied
    (hand mutant: the mean of the signed omega survived every test; it anti-correlates with
    the reference and the peak moves)."""
    import pandas as pd

    from terrain.run import Run
    from terrain.slip.estimate import agrimaro_encoder_lag
    from terrain.vehicles import AGRIMARO

    t = np.arange(0, 40, 0.01)
    speed = 0.2 + np.clip(t - 2.0, 0, 1) + 0.5 * np.clip(t - 8.0, 0, 1) * (t < 12) \
        - 0.7 * np.clip(t - 25.0, 0, 1) + 0.4 * np.clip(t - 31.0, 0, 1) * (t < 35)
    cam = pd.DataFrame({"t_s": t, "v_cx": -speed, "v_cy": np.zeros_like(t)})
    run = Run("sim/ASPHALT/0", "sim", "ASPHALT", {"cam": cam}, vehicle="agrimaro")
    om = -np.interp(t - 0.3, t, speed) / AGRIMARO.wheel_radius_m
    est = agrimaro_encoder_lag(run, t, np.column_stack([om, om, om]))
    assert est.applied and est.lag_s == pytest.approx(0.3, abs=0.005)
    assert est.correlation > 0.99


def test_skid_steer_estimate_counts_its_dead_band_samples(borealtc_runs):
    # the AgriMaRo estimate counted the slips set to 0 by the dead band; the skid-steer one
    # set them without a word (ASPHALT/02 stands still at its start and end)
    from terrain.slip import DEAD_BAND_M_S
    from terrain.slip.estimate import estimate_skid_steer_run, resample
    from terrain.vehicles import get_vehicle

    run = next(r for r in borealtc_runs if r.run_id == "borealtc/ASPHALT/02")
    est = estimate_skid_steer_run(run, lag="none")
    v, r = est.ekf.state("v_bx"), est.ekf.state("yaw_rate")
    half = 0.5 * get_vehicle("husky").track_m
    v_side = np.column_stack([v - r * half, v + r * half])    # seed 001 eq. 7.3 at y = +-B/2
    w = run.streams["wheels"]
    rim = resample(est.ekf.t_s, w["t_s"].to_numpy(float), w[["vel_l", "vel_r"]].to_numpy(float))
    in_band = (np.abs(rim) < DEAD_BAND_M_S) & (np.abs(v_side) < DEAD_BAND_M_S)
    assert in_band.sum() > 50
    note, = [n for n in est.notes if "dead band" in n]
    assert note.startswith(f"note: run borealtc/ASPHALT/02: {int(in_band.sum())} of "
                           f"{in_band.size} wheel slip samples in the {DEAD_BAND_M_S} m/s")
    assert "std_slip" not in note           # the skid-steer estimate has no std
    assert (est.slip[in_band] == 0).all()
