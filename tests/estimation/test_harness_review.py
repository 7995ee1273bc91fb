"""Convergence times of the validation harness (:mod:`pipelines.validation.harness`)."""

from __future__ import annotations

import numpy as np

from pipelines.validation.harness import _conv_time


def test_convergence_time_is_after_the_last_sample_over_the_tolerance():
    t = np.array([10.0, 11.0, 12.0, 13.0, 14.0])
    assert _conv_time(t, np.array([0.2, 0.01, 0.3, 0.01, 0.02])) == 12.0
    assert _conv_time(t, np.full(5, 0.01)) == 10.0          # below from the first sample
    assert np.isnan(_conv_time(t[:0], t[:0]))               # no steady-turn sample


def test_an_error_still_over_the_tolerance_at_the_end_never_converged():
    # the last steady-turn sample over 5 %: the error never stays below it, which read as
    # convergence at that sample (observer eta, random ASPHALT seed 5: 59.98 s of 60 s)
    t = np.array([10.0, 11.0, 12.0, 13.0])
    assert _conv_time(t, np.array([0.01, 0.01, 0.01, 0.2])) == np.inf
    assert _conv_time(t, np.array([0.2, 0.2, 0.2, 0.2])) == np.inf


def test_an_error_that_cannot_be_computed_is_not_below_the_tolerance():
    # a NaN relative error (the observer's yaw rate 0: chi = 0 / 0) passed 'rel_err > tol'
    # as converged: errors [0.2, 0.01, NaN] gave 10.0 s
    t = np.array([10.0, 11.0, 12.0, 13.0])
    assert _conv_time(t, np.array([0.2, np.nan, 0.01, 0.01])) == 11.0
    assert _conv_time(t, np.array([0.2, 0.01, 0.01, np.nan])) == np.inf


class _Result:
    """A stand-in for a simulation or an EKF result: only the attributes read."""

    def __init__(self, **fields):
        self.__dict__.update(fields)


def test_average_nees_is_the_time_mean_of_the_run_average_after_t_min(monkeypatch):
    # planted NEES sequences of two runs (column 0 of the state errors) on t = 0..3 s
    from pipelines.validation import harness
    from terrain.estimation.consistency import mean_chi2_bounds

    planted = {0: [30.0, 12.0, 12.0, 6.0], 1: [30.0, 12.0, 12.0, 50.0]}
    t = np.arange(4.0)

    def estimate(run, settings, store_covariance=False):
        x = np.zeros((4, 12))
        x[:, 0] = planted[run.seed]
        return _Result(t_s=t, x=x, P=None, nis=np.ones(4), dof=np.ones(4))

    monkeypatch.setattr(harness, "simulate_agrimaro",
                        lambda terrain, seed, *a: _Result(run=_Result(seed=seed)))
    monkeypatch.setattr(harness, "estimate_agrimaro", estimate)
    monkeypatch.setattr(harness, "agrimaro_truth_states", lambda result, grid: 0.0)
    monkeypatch.setattr(harness, "state_errors", lambda x, truth, angles: x - truth)
    monkeypatch.setattr(harness, "nees", lambda e, P: e[:, 0])
    row = harness.agrimaro_consistency("GRASS", seeds=[0, 1], t_min_s=1.0,
                                       settings_fn=lambda run: None)
    # run average from t = 1 s: [12, 12, 28]; its time mean, not its median (12)
    assert row.anees == np.mean([12.0, 12.0, 28.0])
    lo, hi = mean_chi2_bounds(12, 2)
    assert lo < 12.0 < hi < 28.0 and row.nees_step_bounds == (lo, hi)
    assert row.nees_fraction_in_bounds == 2 / 3          # 28 is over the upper bound
    assert row.n_runs == 2 and row.nis_mean == 1.0


def test_measured_summary_spans_the_run_not_its_clock_and_medians_the_turns():
    # a simulated Husky run whose clock starts at 100 s (logged runs rarely start at 0)
    from pipelines.validation.harness import measured_skid_steer_summary, simulate_husky
    from terrain.estimation.skid_steer import estimate_skid_steer, icr_chi
    from terrain.run import TIME, Run

    run = simulate_husky("ASPHALT", 1, 12.0, "random").run
    run = Run(run.run_id, run.dataset, run.terrain,
              {k: v.assign(**{TIME: v[TIME] + 100.0}) for k, v in run.streams.items()},
              run.vehicle, run.source, run.meta)
    row = measured_skid_steer_summary([run]).iloc[0]
    ekf = estimate_skid_steer(run)
    turning = np.abs(ekf.state("yaw_rate")) > 0.15
    # (the wheel stream at BorealTC's 6.5 Hz since 2026-11-30 ends on the 12 s mark: the
    # filter's span is then the full 12 s, 11.996 s at the former 6.50195 Hz)
    assert row["duration_s"] == ekf.t_s[-1] - ekf.t_s[0] and 11.9 < row["duration_s"] <= 12.0
    assert row["turning_fraction"] == turning.mean() and 0.0 < turning.mean() < 1.0
    assert row["chi_ekf"] == np.nanmedian(icr_chi(ekf)[turning])
    assert row["gyro_bias"] == ekf.state("gyro_bias")[-1]
