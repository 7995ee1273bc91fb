"""Review (feat5) of the feature calculators, transformers and windowing: bad inputs refused,
formulas pinned by known values (tests written for defects and surviving hand mutants)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from features import calculators as calc
from features.ekf_signals import EKF_CHANNELS, add_ekf_channels
from features.reference import reference_features
from features import slip_features
from features.slip_features import (SLIP_CHANNELS, slip_feature_matrix, slip_targets,
                                    slip_windows)
from features.slip_outputs import slip_model_outputs
from features.transformers import WindowFeatures
from features.windows import WindowSet
from features.wheel_physics import PHYSICS_FEATURES, WheelPhysicsFeatures, physics_features
from terrain.errors import ConfigError
from terrain.io.align import interpolated_mean_count
from terrain.io.measured import read_runs_dir
from terrain.io.writer import write_run
from terrain.run import TIME, Run
from terrain.sim import SimConfig, simulate
from terrain.sim.sensors import SensorSettings
from terrain.slip.physics import physics_slip, pitch_std_from_accelerometer
from terrain.vehicles import get_vehicle


@pytest.mark.parametrize("q", [1.5, -0.1, np.nan])
def test_quantile_sorted_refuses_a_quantile_outside_zero_to_one(q):
    """q outside [0, 1] read past the array's ends (compiled, no bounds check): q 1.5 of
    [1, 2, 3] gave whatever lay in memory there, not an error."""
    with pytest.raises(ValueError, match=r"q must be a number in \[0, 1\]"):
        calc.quantile_sorted(np.array([1.0, 2.0, 3.0]), q)


def test_quantile_sorted_refuses_an_empty_array():
    """No sample has no quantile (it read the memory before the array)."""
    with pytest.raises(ValueError, match="at least one value"):
        calc.quantile_sorted(np.zeros(0), 0.5)


@pytest.mark.parametrize("n", [0, -4, 2.5, True])
def test_band_weights_refuse_a_window_length_that_is_not_a_count(n):
    """0 samples raised Python's bare ZeroDivisionError, -4 NumPy's 'zero-size array to
    reduction operation minimum', 2.5 NumPy's 'n should be an integer', naming no
    argument; True was taken as 1 sample."""
    with pytest.raises(ConfigError, match="band_weights.n_samples must be an integer >= 1"):
        calc.band_weights(n, 50.0, ((0.0, 5.0),))


@pytest.mark.slow
def test_moving_and_turning_fractions_count_speeds_strictly_above_their_scales():
    """A window driven at exactly the speed scale v0 (yaw rate exactly w0) counts as
    standing (straight): moving__fraction is the share of samples with |v| > v0."""
    n = 20
    names = list(PHYSICS_FEATURES)
    track = 0.5
    cur = np.full((1, n), 2.0)

    def fractions(vel_l, vel_r):
        out = physics_features(np.full((1, n), vel_l), np.full((1, n), vel_r), cur, cur,
                               10.0, track_m=track, speed_scale_m_s=0.25,
                               yaw_scale_rad_s=0.5)[0]
        return out[names.index("moving__fraction")], out[names.index("turning__fraction")]

    assert fractions(0.25, 0.25) == (0.0, 0.0)          # |v| = v0: standing
    assert fractions(0.375, 0.375) == (1.0, 0.0)
    assert fractions(0.125, 0.375) == (0.0, 0.0)         # v = v0, omega = 0.25/0.5 = w0
    assert fractions(0.0, 0.5) == (0.0, 1.0)             # v = v0, omega = 1.0 > w0


def _quarter_second_truth(yaw_rate):
    """A simulated run whose truth holds slip_1 = t on a 0.25 s clock (exact sums)."""
    tt = np.arange(0.0, 10.0, 0.25)
    truth = pd.DataFrame({TIME: tt, "slip_1": tt, "slip_2": 0.5, "yaw_rate": yaw_rate,
                          "v_by": 0.0, "terrain": "SNOW"})
    return Run("sim1", "sim", "SNOW", {"truth": truth})


def _two_second_windows(t0):
    n, dv = 100, 0.25
    values = {c: np.zeros((len(t0), n)) for c in SLIP_CHANNELS}
    values.update(vel_l=np.full((len(t0), n), 0.5), vel_r=np.full((len(t0), n), 0.5 + dv),
                  vel_diff=np.full((len(t0), n), dv))
    X = np.stack([values[c] for c in SLIP_CHANNELS], axis=1)
    ids = np.array(["sim1"] * len(t0), dtype=object)
    t0 = np.asarray(t0, dtype=float)
    return WindowSet(X, SLIP_CHANNELS, ids, ids, ids, t0, t0 + 2.0, 50.0)


def test_slip_targets_average_the_truth_inside_the_window_end_excluded():
    """A window is [t_start, t_end): the truth sample at t_end belongs to the next window
    (slip_1 = t on a 0.25 s clock: the 0-2 s window averages 0, 0.25, ..., 1.75 -> 0.875,
    not 1.0 with the sample at 2 s)."""
    Y = slip_targets([_quarter_second_truth(0.5)], _two_second_windows([0.0, 2.0]), 0.5)
    np.testing.assert_allclose(Y["slip_1"], [0.875, 2.875], rtol=0, atol=1e-15)


def test_the_chi_target_is_defined_at_exactly_the_minimum_turn_rate(monkeypatch):
    """chi is NaN only when the robot turns slower than MIN_TURN_RATE_RAD_S (module
    docstring): at exactly that rate it is mean(v_R - v_L) / (B yaw rate)."""
    monkeypatch.setattr(slip_features, "MIN_TURN_RATE_RAD_S", 0.125)   # exact window sums
    Y = slip_targets([_quarter_second_truth(0.125)], _two_second_windows([0.0]), 0.5)
    assert Y.loc[0, "chi"] == 0.25 / (0.5 * 0.125)
    Y = slip_targets([_quarter_second_truth(0.0625)], _two_second_windows([0.0]), 0.5)
    assert np.isnan(Y.loc[0, "chi"])


@pytest.mark.parametrize("scale, shaped", [(3e-6, True), (5e-7, False)])
def test_the_shape_moments_floor_is_a_population_variance_of_1e_12(scale, shaped):
    """Skewness and kurtosis are 0 only where m2 <= 1e-12 (std <= 1e-6 in the channel's
    unit, the documented floor of near-constant windows, as the scipy reference has it):
    9.81 m/s^2 with a spike of 3 um/s^2 (std 3.9e-6) keeps scipy's shape values
    (Bernoulli 1/4: 2/sqrt(3), -2/3); with 0.5 um/s^2 (std 6.5e-7) both are 0."""
    x = (9.81 + scale * np.array([0.0, 0.0, 0.0, 3.0]))[None, None, :]
    got = calc.statistics(x, ("skewness", "kurtosis"))[0, 0]
    if shaped:
        np.testing.assert_allclose(got, [sps.skew(x[0, 0]), sps.kurtosis(x[0, 0])], rtol=1e-6)
        np.testing.assert_allclose(got, [2.0 / np.sqrt(3.0), -2.0 / 3.0], rtol=1e-6)
    else:
        assert got.tolist() == [0.0, 0.0]
    ref = reference_features(x, ("ax",), 50.0)[0]
    assert ref[2:4].tolist() == pytest.approx(got.tolist(), rel=1e-6)


@pytest.mark.parametrize("n", [10, 70])
def test_the_scipy_reference_gives_the_columns_of_window_features_for_any_length(n):
    """The reference took a band's mean over the periodogram bins with ``low <= f < high``
    exactly: 10-sample windows at 50 Hz (5 Hz bins) left 2.5 Hz bands without a bin (NaN,
    where WindowFeatures takes the nearest bin), and at 70 samples rfftfreq's 5 Hz bin
    (4.999999999999999) went to the 2.5-5 Hz band (log power off by 0.42)."""
    rng = np.random.default_rng(1)
    X = rng.standard_normal((3, 2, n))
    want = WindowFeatures(("ax", "wz"), 50.0).fit_transform(X)
    with warnings.catch_warnings():
        warnings.simplefilter("error")       # (no 'Mean of empty slice')
        got = reference_features(X, ("ax", "wz"), 50.0)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)


def test_a_one_row_frame_gets_nan_ekf_channels_not_a_filter_step():
    """A frame shorter than 2 rows gets the EKF channels as NaN (documented); a '< 1'
    mutant ran the filter on one row at an assumed 1 Hz clock (ekf_v_bx 0.547 m/s)."""
    frame = pd.DataFrame({TIME: [0.0], "vel_l": [0.5], "vel_r": [0.6], "wz": [0.1]})
    out = add_ekf_channels(frame)
    assert list(out.columns) == list(frame.columns) + list(EKF_CHANNELS)
    assert out[list(EKF_CHANNELS)].isna().all().all()
    pd.testing.assert_frame_equal(out[list(frame.columns)], frame)


@pytest.mark.slow
def test_slip_model_outputs_are_stamped_at_the_window_centres(tmp_path):
    """Each output's t_s is the centre of its 2 s window (the time a window mean
    describes, documented), one hop (1 s) apart: start + 1 s, not the window start."""
    write_run(simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",),
                                 scenario="straight_accel", duration_s=6.0, seed=3)), tmp_path)
    run = read_runs_dir(tmp_path, dataset="centre")[0]
    ws = slip_windows([run])
    out = slip_model_outputs(run)
    assert len(ws) >= 3
    for key in ("physics", "physics_interval", "physics_current", "physics_transient"):
        np.testing.assert_allclose(out[key][0], ws.t_start_s + 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.diff(out["physics"][0]), 1.0, rtol=0, atol=1e-12)


def test_the_transient_std_is_the_slip_change_beyond_the_current_noise(tmp_path):
    """physics_transient's std is the quadrature difference of the physics std with and
    without the traction that changed inside the window: 0 on the steady windows after
    the acceleration of straight_accel (where physics_current's std, the current noise,
    is not), above the current noise while the robot accelerates; the std with the change
    itself (the mutant that survived) is never 0."""
    write_run(simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",),
                                 scenario="straight_accel", duration_s=6.0, seed=3)), tmp_path)
    out = slip_model_outputs(read_runs_dir(tmp_path, dataset="transient")[0])
    noise, change = out["physics_current"][2], out["physics_transient"][2]
    assert (noise[-2:] > 0).all() and (change[-2:] == 0).all()
    assert (change[0] > noise[0]).all()
    assert (out["physics"][2] >= change).all()


def test_wheel_physics_fit_refuses_windows_without_a_sample():
    """fit took windows of 0 samples and fixed 25 feature names; transform then failed in
    physics_features (ShapeError): the refusal belongs to fit, as WindowFeatures'."""
    X = np.zeros((2, 4, 0))
    with pytest.raises(ValueError, match="at least 1 sample"):
        WheelPhysicsFeatures().fit(X)
    assert WheelPhysicsFeatures().fit(np.ones((2, 4, 1))).transform(np.ones((2, 4, 1))).shape \
        == (2, len(PHYSICS_FEATURES))


@pytest.mark.slow
def test_the_phys_columns_are_the_physics_slip_of_the_window_means(tmp_path):
    """phys_slip_l/_r and phys_std are terrain.slip.physics.physics_slip of the window
    means with the wheel angular acceleration vel_mean__slope / r_w (rad/s^2) and the
    mean of the two sides' stds; mutants multiplying by r_w, or taking the larger std,
    survived. Checked on the accelerating windows of a simulated run."""
    write_run(simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",),
                                 scenario="straight_accel", duration_s=6.0, seed=3)), tmp_path)
    run = read_runs_dir(tmp_path, dataset="phys")[0]
    ws = slip_windows([run])
    vehicle = get_vehicle(run.vehicle)
    probs = {"SANDY_LOAM": np.ones(len(ws))}
    names, f = slip_feature_matrix(ws.X, ws.channels, ws.rate_hz, vehicle, probs)
    col = {n: f[:, j] for j, n in enumerate(names)}
    slope = col["vel_mean__slope"]
    assert np.abs(slope).max() > 0.1                      # the acceleration shows
    want = physics_slip(
        vehicle, probs, np.column_stack([col["cur_l__mean"], col["cur_r__mean"]]),
        np.column_stack([col["vel_l__mean"], col["vel_r__mean"]]), col["pitch"],
        np.column_stack([slope, slope]) / vehicle.contact_geometry().wheel_radius_m,
        n_averaged=interpolated_mean_count(ws.X.shape[-1], ws.rate_hz,
                                           SensorSettings.wheel_rate_hz),
        current_within_std_a=np.column_stack([col["cur_l__std"], col["cur_r__std"]]),
        pitch_std_rad=pitch_std_from_accelerometer(ws.X[:, list(ws.channels).index("ax")]))
    np.testing.assert_array_equal(col["phys_slip_l"], want.slip[:, 0])
    np.testing.assert_array_equal(col["phys_slip_r"], want.slip[:, 1])
    np.testing.assert_array_equal(col["phys_std"], want.std.mean(axis=1))
    assert (want.std[:, 0] != want.std[:, 1]).any()       # mean and max differ here
