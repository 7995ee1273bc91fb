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
