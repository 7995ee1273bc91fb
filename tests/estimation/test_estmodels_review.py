"""Review of the vehicle estimation models (skid-steer, AgriMaRo, the compiled loop and the
consistency statistics): behaviour the other tests of ``tests/estimation`` left open."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError


@pytest.mark.parametrize("kwargs,match", [
    (dict(dof=0), "dof"), (dict(dof=-3), "dof"), (dict(dof=np.nan), "dof"),
    (dict(dof=np.inf), "dof"), (dict(n_samples=np.nan), "n_samples")])
def test_chi2_bounds_of_an_impossible_dof_or_sample_count_are_refused(kwargs, match):
    """``mean_chi2_bounds(0, 10)``, ``(-3, 10)`` and ``(3, nan)`` returned ``(nan, nan)``:
    a consistency test against them is silently never inside."""
    from scipy import stats

    from terrain.estimation.consistency import mean_chi2_bounds
    args = dict(dof=3, n_samples=10) | kwargs
    with pytest.raises(ConfigError, match=match):
        mean_chi2_bounds(**args)
    assert mean_chi2_bounds(3, 10) == pytest.approx(
        (stats.chi2.ppf(0.025, 30) / 10, stats.chi2.ppf(0.975, 30) / 10))


@pytest.mark.parametrize("max_lag", [0, -5])
def test_an_autocorrelation_window_of_no_lag_is_refused(max_lag):
    """``max_lag=-5`` sliced the autocorrelation as ``[1:-5]``: a sum over nearly every lag
    instead of none (tau 1.37 for white noise of 100 samples, where max_lag 1 gives 1)."""
    from terrain.estimation.consistency import (effective_sample_size,
                                                integrated_autocorrelation_time)
    x = np.random.default_rng(0).standard_normal(100)
    with pytest.raises(ConfigError, match="max_lag"):
        integrated_autocorrelation_time(x, max_lag=max_lag)
    with pytest.raises(ConfigError, match="max_lag"):
        effective_sample_size(x, max_lag=max_lag)
    assert float(integrated_autocorrelation_time(x, max_lag=1)) == 1.0


@pytest.mark.parametrize("name", ["accel_std_m_s2", "cam_yaw_std_rad", "omega_std_rad_s"])
@pytest.mark.parametrize("value", [-0.8, 0.0, float("inf")])
def test_a_noise_derived_std_that_is_not_a_finite_number_gt_0_is_refused_by_name(name, value):
    """``noise_derived_settings(accel_std_m_s2=-0.8)`` squared the std into a variance of
    0.64 without a word (a sign error in the caller's noise estimate passed unseen)."""
    from terrain.estimation.agrimaro import noise_derived_settings
    with pytest.raises(ConfigError, match=f"noise_derived_settings.{name}"):
        noise_derived_settings(**{name: value})
    r = noise_derived_settings(accel_std_m_s2=0.5).r_diag
    assert r[3] == r[4] == pytest.approx(0.25)


@pytest.mark.parametrize("arg,value", [
    ("dts", np.full(10, 0.01)), ("P0", np.eye(3)), ("R_diag", np.full(2, 1e-4)),
    ("row_sensor", np.array([0, 0])), ("thresholds", np.array([3.84]))])
def test_the_compiled_loop_refuses_arrays_of_other_sizes_by_name(arg, value):
    """The loop runs without bounds checks: 10 steps for a 50-step run, a 3 x 3 P0 for 4
    states or 2 noise variances for 3 rows were read past their ends and the run returned
    other numbers without a word (e.g. a final speed variance of 1.1e-5 instead of
    3.4e-4 for the short ``dts``); one gate threshold for the two wheel rows likewise."""
    from terrain.errors import ShapeError
    from terrain.estimation.fast import run_compiled
    from terrain.estimation.runner import sensor_groups
    from terrain.estimation.skid_steer import SENSOR_ROWS, SkidSteerModel
    model = SkidSteerModel()
    Z = np.tile([0.4, 0.4, 0.0], (50, 1))
    args = dict(dts=np.full(49, 0.01), P0=model.P0, R_diag=model.R_diag,
                row_sensor=sensor_groups(SENSOR_ROWS, 3), thresholds=np.array([3.84, 5.99]))
    ref = run_compiled(model.fast_kernel(), args["dts"], Z, model.x0, args["P0"],
                       args["R_diag"], args["row_sensor"], 2, thresholds=args["thresholds"])
    assert np.isfinite(ref.P_diag).all()
    args[arg] = value
    with pytest.raises(ShapeError, match=arg):
        run_compiled(model.fast_kernel(), args["dts"], Z, model.x0, args["P0"],
                     args["R_diag"], args["row_sensor"], 2, thresholds=args["thresholds"])


@pytest.mark.parametrize("value", [-0.05, float("nan"), float("inf")])
def test_a_chi_yaw_rate_threshold_that_is_not_a_finite_number_ge_0_is_refused(value):
    """The threshold gates the ``ln(chi)`` column by ``|yaw_rate| >= threshold``: NaN would
    never correct chi (every comparison false), a negative one always (also while driving
    straight, the failure the threshold exists for)."""
    from terrain.estimation.skid_steer import SkidSteerSettings
    with pytest.raises(ConfigError, match="chi_min_yaw_rate_rad_s"):
        SkidSteerSettings(chi_min_yaw_rate_rad_s=value)
    assert SkidSteerSettings(chi_min_yaw_rate_rad_s=0.0).chi_min_yaw_rate_rad_s == 0.0


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_window_with_a_non_finite_sample_is_refused_naming_the_window(bad):
    """The compiled loop reads NaN as "no sample": without the check a window with a gap
    ran silently and skipped its rows, where the caller is told to cut windows at gaps."""
    from terrain.errors import NonFiniteInputError
    from terrain.estimation.skid_steer import skid_steer_on_windows
    W = np.zeros((3, 3, 40))
    W[:, :2, :] = 0.4
    W[1, 2, 17] = bad
    with pytest.raises(NonFiniteInputError, match="window 1 "):
        skid_steer_on_windows(W, 100.0)
    x, y, nis = skid_steer_on_windows(W[[0, 2]], 100.0)
    assert np.isfinite(x).all() and np.isfinite(nis).all()


@pytest.mark.parametrize("dt", [0.01, 0.2])
def test_skid_steer_process_noise_is_the_densities_times_the_step_on_both_engines(dt):
    """``Q = diag(accel, yaw_accel, bias, ln chi densities) dt``: the densities are per
    second, so a 100 Hz filter adds a hundredth of them per step (per step they would make
    the speed and yaw rate 100 times as agile); the compiled loop's kernel forms the same."""
    from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
    s = SkidSteerSettings(accel_psd=0.4, yaw_accel_psd=0.2, bias_psd=1e-6, log_chi_psd=3e-3)
    model = SkidSteerModel(s)
    np.testing.assert_allclose(model.Q(dt), np.diag([0.4, 0.2, 1e-6, 3e-3]) * dt, rtol=1e-12)
    kernel = model.fast_kernel()
    assert kernel.q_per == "second"
    np.testing.assert_allclose(kernel.q_diag, [0.4, 0.2, 1e-6, 3e-3], rtol=1e-12)


def test_each_sensor_gets_its_own_ema_coefficient():
    """The pre-filter of eq. 6.12 per sensor: a step of the camera speed is averaged with
    the camera's alpha (0.5 here: 0, 0.5, 0.75, ...), the wheel rates are left as they are
    (no entry, as in the thesis tuning), the IMU with its own alpha."""
    import pandas as pd

    from terrain.estimation.agrimaro import AgriMaRoEKFSettings, agrimaro_samples
    from terrain.run import Run
    t = np.round(np.arange(6) * 0.01, 10)
    step = np.r_[0.0, np.ones(5)]
    imu = pd.DataFrame({"t_s": t, "ax": step, "ay": 0.0, "wz": 0.0})
    omega = pd.DataFrame({"t_s": t, "omega_1": step, "omega_2": step, "omega_3": step})
    cam = pd.DataFrame({"t_s": t, "v_cx": step, "v_cy": 0.0, "yaw_rate_c": 0.0,
                        "yaw_c": 0.0})
    run = Run("sim/TEST/02", "sim", "TEST", {"imu": imu, "omega": omega, "cam": cam},
              vehicle="agrimaro")
    s = agrimaro_samples(run, AgriMaRoEKFSettings(ema_alpha=(("cam", 0.5), ("imu", 0.25))))
    np.testing.assert_allclose(s["cam"].values[:, 0], 1.0 - np.r_[1.0, 0.5 ** np.arange(1, 6)])
    np.testing.assert_array_equal(s["omega"].values[:, 0], step)
    np.testing.assert_allclose(s["imu"].values[:, 0], 1.0 - np.r_[1.0, 0.25 ** np.arange(1, 6)])


def test_the_speed_bound_holds_the_widest_range_over_its_window():
    """With ``hold_s`` each step keeps the widest range of the steps of the last ``hold_s``
    seconds: rims at 1 m/s until 0.3 s, then (0.2, -0.2) m/s; a 0.25 s hold keeps the upper
    bound at 1 m/s through 0.4 s (steps 0.2-0.4 in the window) and drops it to 0.1 m/s at
    0.5 s, while the lower bound opens to -0.1 m/s as soon as the right side reverses."""
    from terrain.estimation.runner import SensorSamples
    from terrain.estimation.skid_steer_slip import speed_bounds_m_s
    t = np.round(np.arange(0.0, 1.0, 0.1), 10)
    wheels = SensorSamples(np.array([0.0, 0.3]), np.array([[1.0, 1.0], [0.2, -0.2]]))
    lo, up = speed_bounds_m_s(t, wheels, 0.0, 0.0, hold_s=0.25)
    np.testing.assert_allclose(up, np.r_[np.full(5, 1.0), np.full(5, 0.1)], rtol=1e-12)
    np.testing.assert_allclose(lo, np.r_[np.zeros(3), np.full(7, -0.1)], rtol=1e-12)
    lo0, up0 = speed_bounds_m_s(t, wheels, 0.0, 0.0)               # no hold
    np.testing.assert_allclose(up0, np.r_[np.full(3, 1.0), np.full(7, 0.1)], rtol=1e-12)


def test_a_pseudo_measurement_of_two_stds_uses_the_larger_for_both_sides():
    """``pseudo_std`` of shape (k, 2): the larger side's std is that of both slip rows (the
    conservative one), so (0.05, 0.2) runs as (0.2, 0.2), not as (0.05, 0.05)."""
    from terrain.estimation.runner import SensorSamples
    from terrain.estimation.skid_steer_slip import SkidSteerSlipSettings, run_with_pseudo_slip
    t = np.arange(201) / 100.0
    samples = {"wheels": SensorSamples(t, np.full((t.size, 2), 0.3))}
    tp, slip = np.array([0.5, 1.5]), np.full((2, 2), 0.1)
    runs = {name: run_with_pseudo_slip(t, samples, SkidSteerSlipSettings(), tp, slip,
                                       np.tile(std, (2, 1)))
            for name, std in (("mixed", [0.05, 0.2]), ("wide", [0.2, 0.2]),
                              ("narrow", [0.05, 0.05]))}
    for name in ("x", "P_diag", "S_diag"):
        np.testing.assert_array_equal(getattr(runs["mixed"], name), getattr(runs["wide"], name))
    rows = [3, 4]                                                # slip_1, slip_2
    k = np.flatnonzero(runs["mixed"].accepted[:, 3])
    assert k.size == 2
    assert np.all(runs["mixed"].S_diag[np.ix_(k, rows)] > 0.04)
    assert np.all(runs["narrow"].S_diag[np.ix_(k, rows)] < 0.04)


def test_the_wheel_variance_is_inflated_for_repeats_and_never_deflated():
    """``max(1, grid rate / wheel rate)``: a 100 Hz wheel stream on a 400 Hz grid repeats
    each sample 4 times (variance x 4); on a 50 Hz grid no sample repeats, and the variance
    must not shrink below the sensor's own (a factor 0.5 would double the wheels' weight)."""
    from terrain.estimation.skid_steer import wheel_r_scale
    assert wheel_r_scale(400.0, 100.0) == pytest.approx(4.0)
    assert wheel_r_scale(50.0, 100.0) == 1.0
    assert wheel_r_scale(100.0, 100.0) == 1.0
    assert wheel_r_scale(50.0, None) == 1.0


@pytest.mark.parametrize("kwargs,match", [
    (dict(q_diag=(-1e-3,) * 12), "q_diag must be >= 0"),
    (dict(p0_diag=(-1e-6,) + (1e-5,) * 11), "p0_diag must be >= 0"),
    (dict(q_diag=(np.nan,) * 12), "q_diag needs 12 finite values"),
    (dict(p0_diag=(np.inf,) * 12), "p0_diag needs 12 finite values"),
    (dict(r_diag=(np.nan,) + (1e-3,) * 13), "r_diag needs 14 finite values")])
def test_agrimaro_tuning_that_is_not_a_covariance_is_refused_by_name(kwargs, match):
    """A negative process variance makes ``P`` indefinite (the AgriMaRo settings'
    check of it was untested, as was their finiteness check); the thesis tuning passes."""
    from terrain.estimation.agrimaro import AgriMaRoEKFSettings
    with pytest.raises(ConfigError, match=match):
        AgriMaRoEKFSettings(**kwargs)
    assert AgriMaRoEKFSettings(q_diag=(0.0,) * 12).q_diag == (0.0,) * 12


def test_an_exactly_singular_innovation_covariance_fails_the_factorisation():
    """A zero pivot is not positive definite: the Cholesky factorisation must stop there
    (named as such) instead of dividing by zero and reaching the NIS check with NaN."""
    from terrain.errors import CovarianceError
    from terrain.estimation.fast import run_compiled
    from terrain.estimation.skid_steer import SkidSteerModel
    model = SkidSteerModel()
    Z = np.array([[np.nan, np.nan, 0.1], [np.nan, np.nan, 0.1]])     # the gyro row only
    r_gyro = model.R_diag[2]
    P0 = np.diag([1.0, -0.5 * r_gyro, -0.5 * r_gyro, 1.0])         # H P H^T = -R exactly
    with pytest.raises(CovarianceError, match="Cholesky failed at step 0"):
        run_compiled(model.fast_kernel(), np.full(1, 0.01), Z, model.x0, P0, model.R_diag,
                     np.array([0, 0, 1]), 2)


@pytest.mark.parametrize("kwargs", [{"accel_std_m_s2": -0.8}, {"omega_std_rad_s": -0.2},
                                    {"omega_std_rad_s": "0.2"}, {"accel_std_m_s2": np.nan}])
def test_the_noise_derived_slip_state_model_refuses_stds_that_are_not_positive(kwargs):
    """A negative standard deviation was squared into a valid-looking variance (-0.8 m/s^2
    gave the 0.64 of +0.8) and text raised Python's TypeError on ``'0.2' ** 2``; as
    :func:`~terrain.estimation.agrimaro.noise_derived_settings` does, each is a ConfigError
    naming the argument."""
    from terrain.estimation.slip_state import noise_derived_slip_state_model

    name = next(iter(kwargs))
    with pytest.raises(ConfigError, match=rf"noise_derived_slip_state_model\.{name}"):
        noise_derived_slip_state_model(**kwargs)
