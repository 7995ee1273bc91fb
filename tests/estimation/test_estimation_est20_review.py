"""Review tests (est20): metamorphic relations of the EKF correction and of the skid-steer
filter's clock.

Rows of a measurement given in another order (with their groups), one correction with
independent rows against the rows one after the other, and a run whose clock is shifted by
a constant must give the same estimate.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipelines.validation.harness import simulate_husky
from terrain.estimation.consistency import (effective_sample_size,
                                            integrated_autocorrelation_time)
from terrain.estimation.ekf import Gate, correct
from terrain.estimation.skid_steer import estimate_skid_steer, skid_steer_on_windows
from terrain.run import TIME


def _problem(seed: int, n: int, m: int):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n))
    P = a @ a.T + 1e-3 * np.eye(n)
    return (rng.normal(size=n), P, 3.0 * rng.normal(size=m), rng.normal(size=(m, n)),
            rng.uniform(0.1, 2.0, m), rng)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 31), n=st.integers(1, 5), m=st.integers(1, 5))
def test_correct_rows_in_another_order_give_the_same_posterior_and_gating(seed, n, m):
    """Measurement rows permuted (innovation, H, R and the gated groups alike): the same
    posterior, NIS and accepted rows; R as a vector or as its diagonal matrix, checked or
    not, agree."""
    x, P, y, H, r, rng = _problem(seed, n, m)
    gate = Gate(0.9)
    groups = [np.array([i]) for i in range(m)]
    x1, P1, i1 = correct(x, P, y, H, r, gate=gate, groups=groups)
    perm = rng.permutation(m)
    where = np.argsort(perm)
    x2, P2, i2 = correct(x, P, y[perm], H[perm], r[perm], gate=gate,
                         groups=[np.array([where[i]]) for i in range(m)])
    np.testing.assert_allclose(x2, x1, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(P2, P1, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(i2.accepted, i1.accepted[perm])
    if i1.accepted.any():
        np.testing.assert_allclose(i2.nis, i1.nis, rtol=1e-9)
    else:
        assert np.isnan(i1.nis) and np.isnan(i2.nis)
    for R, check in ((np.diag(r), True), (r, False), (np.diag(r), False)):
        # the unchecked path (the runner's) keeps a vector R as a vector: the same answer
        x3, P3, i3 = correct(x, P, y, H, R, gate=gate, groups=groups, check=check)
        np.testing.assert_allclose(x3, x1, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(P3, P1, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(i3.S, i1.S, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(i3.accepted, i1.accepted)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 31), n=st.integers(1, 5), m=st.integers(1, 5))
def test_correct_batch_equals_rows_one_by_one_and_nis_is_the_innovation_norm(seed, n, m):
    """Independent rows (diagonal R) in one correction or one after the other (each
    innovation re-linearised about the new state, a linear h): the same posterior; the
    posterior covariance is symmetric PSD and no larger than the prior; the NIS is
    ``y^T S^-1 y`` with ``S = H P H^T + R`` (seed 001 eq. 4.14)."""
    x, P, y, H, r, _ = _problem(seed, n, m)
    xb, Pb, ib = correct(x, P, y, H, r)
    xs, Ps = x, P
    for i in range(m):
        xs, Ps, _ = correct(xs, Ps, y[i:i + 1] - H[i] @ (xs - x), H[i:i + 1], r[i:i + 1])
    np.testing.assert_allclose(xs, xb, rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(Ps, Pb, rtol=1e-7, atol=1e-8)
    np.testing.assert_array_equal(Pb, Pb.T)
    assert np.linalg.eigvalsh(Pb).min() >= -1e-9
    assert np.linalg.eigvalsh(P - Pb).min() >= -1e-7 * max(1.0, np.abs(P).max())
    S = H @ P @ H.T + np.diag(r)
    np.testing.assert_allclose(ib.S, S, rtol=1e-12, atol=1e-12)
    assert ib.nis == pytest.approx(float(y @ np.linalg.solve(S, y)), rel=1e-7)


@pytest.fixture(scope="module")
def husky_run():
    """10 s of mixed driving on asphalt (IMU and wheel samples on the 100 Hz grid)."""
    return simulate_husky("ASPHALT", seed=4, duration_s=10.0, icr_expansion=1.5,
                          gyro_bias=0.01).run


def _shifted(run, shift_s: float):
    streams = {}
    for name, frame in run.streams.items():
        frame = frame.copy()
        frame[TIME] = frame[TIME] + shift_s
        streams[name] = frame
    return dataclasses.replace(run, streams=streams)


def test_skid_steer_filter_at_a_given_rate_ignores_a_clock_shift(husky_run):
    """The same run on a clock that starts a day (1e5 s) later, at a given filter rate: the
    same estimate."""
    a = estimate_skid_steer(husky_run, rate_hz=100.0)
    b = estimate_skid_steer(_shifted(husky_run, 1e5), rate_hz=100.0)
    np.testing.assert_allclose(b.t_s - 1e5, a.t_s, atol=1e-9)
    np.testing.assert_allclose(b.x, a.x, atol=1e-9)


def test_skid_steer_filter_at_its_default_rate_ignores_a_clock_shift(husky_run):
    """The same run on a clock that starts a day later, at the filter's default rate (the
    IMU's median sample rate): the same estimate."""
    a = estimate_skid_steer(husky_run)
    b = estimate_skid_steer(_shifted(husky_run, 1e5))
    np.testing.assert_allclose(b.x, a.x, atol=1e-6)


@pytest.mark.parametrize("value", [0.1, 0.3, 2.2, 7.1, 1e6 + 0.1, -0.0])
def test_constant_series_has_autocorrelation_time_1_whatever_its_value(value):
    """A constant row has ``tau = 1`` (documented): 0.3 repeated 500 times gave 498.8 (its
    mean is 5.6e-17 off 0.3, so the residuals were one tiny constant, perfectly
    correlated) where 0.1 gave 1, and its effective sample size was 1 instead of 500."""
    x = np.full(500, value)
    assert integrated_autocorrelation_time(x) == 1.0
    assert effective_sample_size(x) == 500.0
    rows = np.stack([x, np.full(500, 0.1), np.full(500, np.nan)])
    np.testing.assert_array_equal(integrated_autocorrelation_time(rows), [1.0, 1.0, np.nan])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 31), scale=st.sampled_from([1e-3, 3.0, -2.0]),
       offset=st.sampled_from([0.0, 0.3, -50.0]))
def test_autocorrelation_time_is_affine_invariant(seed, scale, offset):
    """``tau`` of ``scale x + offset`` is ``tau`` of ``x`` (a correlation does not see units
    or a bias)."""
    rng = np.random.default_rng(seed)
    x = np.convolve(rng.normal(size=400), np.ones(5) / 5, "same")
    np.testing.assert_allclose(integrated_autocorrelation_time(scale * x + offset),
                               integrated_autocorrelation_time(x), rtol=1e-6)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2 ** 31), n_win=st.integers(1, 3))
def test_skid_steer_windows_mirror_backward_and_batching(seed, n_win):
    """The skid-steer EKF on windows: sides swapped and the gyro negated mirror the turn
    (yaw rate and gyro bias negated, speed and chi kept); every input negated drives it
    backward (speed, yaw rate and bias negated, chi kept); windows in another order or one
    at a time give the same per-window results; the NIS does not change."""
    rng = np.random.default_rng(seed)
    t = np.arange(150) / 100.0
    k = rng.uniform(0.5, 4.0, (n_win, 1))
    turn = 0.4 * np.sin(k * t)
    W = np.stack([1.0 - turn, 1.1 + turn, 1.6 * turn], axis=1) \
        + 0.01 * rng.normal(size=(n_win, 3, t.size))
    x, y, nis = skid_steer_on_windows(W, 100.0)
    xm, _, nism = skid_steer_on_windows(W[:, [1, 0, 2]] * np.array([1, 1, -1])[:, None],
                                        100.0)
    np.testing.assert_allclose(xm, x * [1, -1, -1, 1], atol=1e-9)
    np.testing.assert_allclose(nism, nis, rtol=1e-7, atol=1e-9)
    xb, _, nisb = skid_steer_on_windows(-W, 100.0)
    np.testing.assert_allclose(xb, x * [-1, -1, -1, 1], atol=1e-9)
    np.testing.assert_allclose(nisb, nis, rtol=1e-7, atol=1e-9)
    xr, _, _ = skid_steer_on_windows(W[::-1], 100.0)
    np.testing.assert_array_equal(xr[::-1], x)
    x1, _, nis1 = skid_steer_on_windows(W[-1:], 100.0)
    np.testing.assert_array_equal(x1[0], x[-1])
    np.testing.assert_array_equal(nis1[0], nis[-1])


@pytest.mark.parametrize("t0", [0.0, 3.7, 1e5, 1.7e9])
@pytest.mark.parametrize("rate", [100.0, 30.0, 400.0])
def test_default_rate_read_off_a_clock_keeps_every_sample_on_its_step(t0, rate):
    """``clock_rate_hz`` of evenly spaced samples on a clock starting anywhere (an epoch
    clock included): a grid at that rate from the first sample to a time between two
    samples (another stream's end) puts sample k on step k (the median step alone drifted
    past the placement slack at 1e5 s, 100 Hz, and at 1.7e9 s, 100 and 30 Hz)."""
    from terrain.estimation.runner import clock_rate_hz, make_grid, sample_steps
    t = t0 + np.arange(3000) / rate
    grid = make_grid(float(t[0]), float(t[-1]) - 0.3 / rate, clock_rate_hz(t))
    assert grid.size == t.size - 1
    np.testing.assert_array_equal(sample_steps(grid, t[:-1]), np.arange(t.size - 1))


def test_default_rate_of_a_jittered_clock_is_its_median_step():
    """A clock whose steps vary by more than its rounding (jitter, a gap) keeps the rate of
    its median step: the snap corrects the clock's rounding, nothing else."""
    from terrain.estimation.runner import clock_rate_hz
    rng = np.random.default_rng(3)
    dt = 0.01 + 1e-5 * rng.standard_normal(999)
    dt[500] = 0.5                                          # a gap
    t = np.concatenate([[0.0], np.cumsum(dt)])
    assert clock_rate_hz(t) == 1.0 / np.median(np.diff(t))
