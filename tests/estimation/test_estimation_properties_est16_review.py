"""Property-based checks of the estimation area (hypothesis) that the est14 round left out:
the speed bound's hold against a brute-force window maximum, mirror symmetry of the
skid-steer models (left / right swapped), invariance of a run under a shift of every
timestamp, the segmented pseudo-slip run against one run of the whole grid, the Joseph
update against the textbook gain and covariance, and the consistency statistics against
their definitions with scipy's chi-square."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrain.estimation.runner import SensorSamples, make_grid, sample_steps
from terrain.estimation.skid_steer_slip import (rim_speed_range_m_s, run_with_pseudo_slip,
                                                speed_bounds_m_s)

FAST = settings(max_examples=40, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
TRACK_M = 0.5708


@FAST
@given(seed=st.integers(0, 2**32 - 1), hold=st.sampled_from([0.0, 0.05, 0.3, 1.0]),
       first=st.integers(0, 30), p_nan=st.floats(0.0, 0.5))
def test_speed_bound_is_the_widest_range_of_the_last_hold_seconds_by_brute_force(
        seed, hold, first, p_nan):
    """Each step's range covers the range of the latest finite wheel sample of every step
    of (t - hold, t]; a step whose window reaches a step with no sample yet is unbounded
    (-inf, inf), never NaN (a NaN bound stopped run_filter)."""
    rng = np.random.default_rng(seed)
    grid = make_grid(0.0, 2.0, 20.0)
    tw = np.sort(rng.choice(np.arange(-0.2, 2.1, 0.05), size=25, replace=False)) + 0.001
    rim = rng.normal(0.3, 0.5, size=(tw.size, 2))
    rim[rng.uniform(size=rim.shape) < p_nan] = np.nan
    rim[:min(first, tw.size)] = np.nan                   # a leading dropout
    lo, up = speed_bounds_m_s(grid, SensorSamples(tw, rim), -0.3, 0.09, hold)
    assert not np.isnan(lo).any() and not np.isnan(up).any()
    ok = np.isfinite(rim).all(axis=1)
    steps = sample_steps(grid, tw[ok])
    own_lo = np.full(grid.size, -np.inf)
    own_up = np.full(grid.size, np.inf)
    for k in range(grid.size):
        at = np.flatnonzero(steps <= k)
        if at.size:
            a, b = rim_speed_range_m_s(rim[ok][at[-1]][None], -0.3, 0.09)
            own_lo[k], own_up[k] = a[0], b[0]
    for k in range(grid.size):
        win = [j for j in range(k + 1) if grid[j] > grid[k] - hold + 1e-9] if hold else [k]
        np.testing.assert_allclose([lo[k], up[k]], [own_lo[win].min(), own_up[win].max()],
                                   rtol=1e-12, err_msg=f"step {k}")


def test_a_wheel_stream_that_starts_with_a_dropout_runs_with_the_speed_bound():
    """Wheels at 10 Hz whose first sample is NaN (a dropout as the log starts): the steps
    before the first finite sample have no speed bound; run_with_pseudo_slip stopped on
    'step_bounds hold NaN or a lower bound above its upper bound'."""
    tw, ti = np.arange(0.0, 3.0, 0.1), np.arange(0.0, 3.0, 0.01)
    v = np.full((tw.size, 2), 0.5)
    v[0] = np.nan
    samples = {"wheels": SensorSamples(tw, v), "gyro": SensorSamples(ti, np.zeros((ti.size, 1)))}
    grid = make_grid(0.0, 2.9, 100.0)
    res = run_with_pseudo_slip(grid, samples)
    assert np.isfinite(res.x).all()
    assert res.x[-1, 0] == pytest.approx(0.5, abs=0.05)
    lo, up = speed_bounds_m_s(grid, samples["wheels"], -0.3, 0.09, 1.0)
    assert (lo[:10] == -np.inf).all() and (up[:10] == np.inf).all()
    assert np.isfinite(lo[-1]) and np.isfinite(up[-1])


# ---------------------------------------------------------------- mirror symmetry (left/right)

def _mirror_slip_state(x):
    """Left and right swapped: yaw rate and gyro bias negated, the two side slips swapped."""
    m = np.array(x, dtype=float)
    m[1], m[2] = -x[1], -x[2]
    m[4], m[5] = x[5], x[4]
    return m


@FAST
@given(v=st.floats(-3, 3), w=st.floats(-2, 2), b=st.floats(-0.1, 0.1), lc=st.floats(-1, 2),
       s1=st.floats(-0.99, 0.99), s2=st.floats(-0.99, 0.99), a=st.floats(-3, 3),
       th=st.floats(-1, 1))
def test_slip_model_rows_are_mirror_symmetric(v, w, b, lc, s1, s2, a, th):
    """Swapping the sides (yaw rate, gyro bias negated, slip_1 <-> slip_2) swaps vel_l and
    vel_r and the slip rows and negates wz; the accelerometer rows are unchanged; the
    Jacobian transforms the same way (H(Mx) = N H(x) M)."""
    from terrain.estimation.skid_steer_slip import SkidSteerSlipModel
    model = SkidSteerSlipModel()
    x = np.array([v, w, b, lc, s1, s2, a, th])
    hx, H = model.observation(x)
    hm, Hm = model.observation(_mirror_slip_state(x))
    N = np.eye(7)[[1, 0, 2, 4, 3, 5, 6]]
    N[2, 2] = -1.0
    M = np.eye(8)[[0, 1, 2, 3, 5, 4, 6, 7]]
    M[1, 1] = M[2, 2] = -1.0
    np.testing.assert_allclose(hm, N @ hx, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(Hm, N @ H @ M, rtol=1e-12, atol=1e-12)


def _skid_run(seed, n=200, rate=100.0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    v = rng.uniform(-1, 1) + 0.2 * np.sin(t * rng.uniform(0.5, 3))
    w = rng.uniform(-0.6, 0.6) * np.cos(t * rng.uniform(0.2, 2))
    half = 1.4 * TRACK_M * w / 2
    wheels = np.column_stack([v - half, v + half]) + 0.02 * rng.normal(size=(n, 2))
    gyro = w + 0.01 + 0.005 * rng.normal(size=n)
    return t, wheels, gyro


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), engine=st.sampled_from(["numpy", "numba"]))
def test_a_mirrored_skid_steer_run_negates_yaw_rate_and_bias_and_keeps_speed_and_chi(seed,
                                                                                     engine):
    """vel_l <-> vel_r and wz -> -wz: v_bx and ln(chi) are the same, yaw rate and gyro bias
    change sign, at every step, on both engines (the prior is symmetric: yaw rate and bias
    0, diagonal P0)."""
    from terrain.estimation.runner import run_filter
    from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
    model = SkidSteerModel(SkidSteerSettings(chi0=1.4))
    t, wheels, gyro = _skid_run(seed)
    a = run_filter(model, t, {"wheels": SensorSamples(t, wheels),
                              "gyro": SensorSamples(t, gyro[:, None])}, engine=engine)
    b = run_filter(model, t, {"wheels": SensorSamples(t, wheels[:, ::-1]),
                              "gyro": SensorSamples(t, -gyro[:, None])}, engine=engine)
    sign = np.array([1.0, -1.0, -1.0, 1.0])
    np.testing.assert_allclose(b.x, a.x * sign, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.P_diag, a.P_diag, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(b.nis, a.nis, rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------- time shift / chunking invariance

@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), shift=st.sampled_from([-50.0, -0.125, 3.0, 1000.0]),
       engine=st.sampled_from(["numpy", "numba"]))
def test_a_run_does_not_depend_on_the_origin_of_its_clock(seed, shift, engine):
    """Every timestamp (grid and samples) shifted by the same number of seconds (exact in
    binary): the same estimate, covariance and counts."""
    from terrain.estimation.runner import run_filter
    from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
    model = SkidSteerModel(SkidSteerSettings(chi0=1.4))
    t, wheels, gyro = _skid_run(seed)
    tw = t[::3] + 0.004

    def run(c):
        return run_filter(model, t + c, {"wheels": SensorSamples(tw + c, wheels[::3]),
                                         "gyro": SensorSamples(t + c, gyro[:, None])},
                          engine=engine)
    a, b = run(0.0), run(shift)
    np.testing.assert_allclose(b.x, a.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.P_diag, a.P_diag, rtol=1e-9, atol=1e-15)
    assert a.counts == b.counts


def _slip_samples(seed, n=151, rate=50.0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    v = rng.uniform(0.2, 1.0) + 0.2 * np.sin(t)
    w = rng.uniform(-0.4, 0.4) * np.cos(t)
    half = 1.4 * TRACK_M * w / 2
    wheels = np.column_stack([v - half, v + half]) / 0.9 + 0.01 * rng.normal(size=(n, 2))
    acc = np.column_stack([0.2 * np.cos(t), 9.8 + 0 * t]) + 0.05 * rng.normal(size=(n, 2))
    return t, {"wheels": SensorSamples(t + 0.001, wheels),
               "gyro": SensorSamples(t, (w + 0.01 * rng.normal(size=n))[:, None]),
               "accel": SensorSamples(t, acc)}


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 8), bound=st.booleans())
def test_segmented_pseudo_slip_run_with_one_std_equals_one_run_of_the_whole_grid(
        seed, k, bound):
    """run_with_pseudo_slip cuts the grid after each pseudo-measurement and hands x, P from
    segment to segment; with the same std for every window (and no drift scaling) every
    segment has the same model, so the result is one run_filter over the whole grid with the
    pseudo-measurements as a sensor (states, covariances, counts)."""
    from terrain.estimation.runner import run_filter
    from terrain.estimation.skid_steer_slip import (SPEED_BOUND_MOVABLE, SkidSteerSlipModel,
                                                    SkidSteerSlipSettings, _speed_bounds)
    rng = np.random.default_rng(seed)
    t, s = _slip_samples(seed)
    tp = np.sort(rng.choice(np.arange(0.1, 2.95, 0.05), size=k, replace=False)) + 0.003
    sp = rng.uniform(-0.3, 0.5, size=(k, 2))
    cfg = SkidSteerSlipSettings(speed_bound_braking_slip=-0.3 if bound else None)
    a = run_with_pseudo_slip(t, s, cfg, tp, sp, np.full(k, cfg.slip_std))
    b = run_filter(SkidSteerSlipModel(cfg), t, {**s, "slip_model": SensorSamples(tp, sp)},
                   engine="numpy", store_covariance=True, step_bounds=_speed_bounds(
                       t, s["wheels"], cfg), step_bound_movable=SPEED_BOUND_MOVABLE)
    np.testing.assert_allclose(a.x, b.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(a.P, b.P, rtol=1e-9, atol=1e-14)
    assert a.counts == b.counts


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), use_position=st.booleans())
def test_the_adaptive_observer_of_a_mirrored_run_swaps_the_two_etas(seed, use_position):
    """Seed 000 eq. 8 under the mirror (y -> -y, theta -> -theta, v_R <-> v_L, gains
    l1 = l2 and lambda1 = lambda2): eta_R and eta_L trade places and the pose estimate is
    mirrored, at every sample."""
    from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer
    rng = np.random.default_rng(seed)
    n, d = 300, TRACK_M / 2
    t = np.cumsum(rng.uniform(0.005, 0.015, n))
    vr, vl = rng.uniform(0.2, 1.0) + 0.05 * rng.normal(size=n), \
        rng.uniform(0.2, 1.0) + 0.05 * rng.normal(size=n)
    er, el = rng.uniform(0.5, 1.0, 2)
    w = (er * vr - el * vl) / (2 * d)
    th = np.cumsum(w * np.r_[0.0, np.diff(t)]) + rng.uniform(-3, 3)
    v = (er * vr + el * vl) / 2
    x = np.cumsum(v * np.cos(th) * np.r_[0.0, np.diff(t)])
    y = np.cumsum(v * np.sin(th) * np.r_[0.0, np.diff(t)])
    cfg = AdaptiveObserverSettings(eta0=tuple(rng.uniform(0.5, 1.5, 2)),
                                   use_position=use_position)
    mirrored = AdaptiveObserverSettings(eta0=cfg.eta0[::-1], use_position=use_position)
    a = run_adaptive_observer(t, np.column_stack([x, y, th]), vr, vl, cfg)
    b = run_adaptive_observer(t, np.column_stack([x, -y, -th]), vl, vr, mirrored)
    np.testing.assert_allclose(b.eta, a.eta[:, ::-1], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.pose_hat, a.pose_hat * [1.0, -1.0, -1.0], rtol=1e-9,
                               atol=1e-9)


# ----------------------------------------------------------- Joseph form against the textbook

def _spd(rng, n, scale=1.0):
    a = rng.normal(size=(n, n))
    return scale * (a @ a.T + 1e-2 * np.eye(n))


@FAST
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 6), m=st.integers(1, 5),
       full_r=st.booleans())
def test_joseph_update_equals_the_textbook_gain_covariance_and_nis(seed, n, m, full_r):
    """correct() against seed 001 eqs. 4.9-4.12 written out with explicit inverses:
    S = H P H^T + R, K = P H^T S^-1, x + K y, (I - K H) P (equal to the Joseph form for
    this optimal gain), NIS = y^T S^-1 y and the per-row normalised innovation."""
    from terrain.estimation.ekf import correct
    rng = np.random.default_rng(seed)
    x, P = rng.normal(size=n), _spd(rng, n)
    H = rng.normal(size=(m, n))
    R = _spd(rng, m, 0.1) if full_r else rng.uniform(0.05, 2.0, m)
    Rm = R if full_r else np.diag(R)
    y = rng.normal(size=m)
    x1, P1, inn = correct(x, P, y, H, R)
    S = H @ P @ H.T + Rm
    K = P @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(inn.S, S, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(x1, x + K @ y, rtol=1e-8, atol=1e-10)
    scale = np.abs(P).max()
    np.testing.assert_allclose(P1, (np.eye(n) - K @ H) @ P, rtol=1e-7, atol=1e-9 * scale)
    A = np.eye(n) - K @ H
    np.testing.assert_allclose(P1, A @ P @ A.T + K @ Rm @ K.T, rtol=1e-7, atol=1e-9 * scale)
    assert inn.nis == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-8)
    np.testing.assert_allclose(inn.normalised, y / np.sqrt(np.diag(S)), rtol=1e-12)
    assert inn.dof == m and inn.accepted.all()
    # the update never adds uncertainty: P - P1 is PSD
    assert np.linalg.eigvalsh(P - P1)[0] >= -1e-9 * scale


@FAST
@given(seed=st.integers(0, 2**32 - 1), p=st.floats(0.5, 0.9999), m=st.integers(1, 4))
def test_the_gate_rejects_a_group_exactly_when_its_nis_exceeds_the_chi2_quantile(seed, p, m):
    from scipy import stats

    from terrain.estimation.ekf import Gate, correct
    rng = np.random.default_rng(seed)
    n = 3
    x, P = rng.normal(size=n), _spd(rng, n)
    H = rng.normal(size=(m, n))
    R = rng.uniform(0.1, 1.0, m)
    y = rng.normal(scale=rng.uniform(0.1, 10.0), size=m)
    gate = Gate(p)
    x1, P1, inn = correct(x, P, y, H, R, gate=gate)
    S = H @ P @ H.T + np.diag(R)
    d2 = y @ np.linalg.solve(S, y)
    thr = stats.chi2.ppf(p, m)
    assert gate.threshold(m) == pytest.approx(thr, rel=1e-12)
    if abs(d2 - thr) > 1e-9 * thr:
        assert inn.accepted.all() == (d2 <= thr)
    if not inn.accepted.any():
        np.testing.assert_array_equal(x1, x)
        np.testing.assert_array_equal(P1, P)
        assert np.isnan(inn.nis) and inn.dof == 0


# ------------------------------------------------- consistency statistics against definitions

@FAST
@given(seed=st.integers(0, 2**32 - 1), N=st.integers(1, 30), n=st.integers(1, 5),
       a=st.floats(1e-3, 1e3))
def test_nees_is_its_definition_and_invariant_to_a_change_of_units(seed, N, n, a):
    """NEES_k = e_k^T P_k^-1 e_k step by step; scaling the errors by a (a change of unit)
    and the covariances by a^2 leaves it unchanged."""
    from terrain.estimation.consistency import nees
    rng = np.random.default_rng(seed)
    P = np.stack([_spd(rng, n) for _ in range(N)])
    e = rng.normal(size=(N, n))
    v = nees(e, P)
    want = [e[k] @ np.linalg.inv(P[k]) @ e[k] for k in range(N)]
    np.testing.assert_allclose(v, want, rtol=1e-8)
    np.testing.assert_allclose(nees(a * e, a * a * P), v, rtol=1e-8)
    assert (v >= 0).all()


@FAST
@given(dof=st.floats(0.5, 20), n=st.floats(1, 5000), p=st.floats(0.5, 0.999))
def test_mean_chi2_bounds_are_the_quantiles_of_the_scaled_sum(dof, n, p):
    """The mean of n chi2(dof) values, times n, is chi2(n dof): its two-sided p interval is
    chi2.ppf((1 -+ p) / 2, n dof) / n, holds dof, and the bounds nest as p grows."""
    from scipy import stats

    from terrain.estimation.consistency import mean_chi2_bounds
    lo, hi = mean_chi2_bounds(dof, n, p)
    assert lo == pytest.approx(stats.chi2.ppf((1 - p) / 2, n * dof) / n, rel=1e-12)
    assert hi == pytest.approx(stats.chi2.ppf((1 + p) / 2, n * dof) / n, rel=1e-12)
    assert stats.chi2.cdf(hi * n, n * dof) - stats.chi2.cdf(lo * n, n * dof) == \
        pytest.approx(p, abs=1e-9)
    assert lo < dof < hi
    lo2, hi2 = mean_chi2_bounds(dof, n, min(p + 0.0005, 0.9999))
    assert lo2 <= lo and hi <= hi2


@FAST
@given(seed=st.integers(0, 2**32 - 1), N=st.integers(1, 200), p=st.floats(0.5, 0.99))
def test_chi2_test_mean_dof_and_pointwise_fraction_are_their_definitions(seed, N, p):
    """Over the finite values with dof > 0: mean, mean dof, count, and the fraction inside
    each value's own [chi2.ppf((1-p)/2, d_k), chi2.ppf((1+p)/2, d_k)] (scipy)."""
    from scipy import stats

    from terrain.estimation.consistency import chi2_test
    rng = np.random.default_rng(seed)
    d = rng.integers(0, 5, N).astype(float)
    v = rng.chisquare(np.maximum(d, 1)) * rng.uniform(0.5, 2.0)
    v[rng.uniform(size=N) < 0.1] = np.nan
    res = chi2_test(v, d, p)
    ok = np.isfinite(v) & (d > 0)
    assert res.n_samples == int(ok.sum())
    if not ok.any():
        assert np.isnan(res.mean)
        return
    assert res.mean == pytest.approx(v[ok].mean(), rel=1e-12)
    assert res.dof == pytest.approx(d[ok].mean(), rel=1e-12)
    lo = stats.chi2.ppf((1 - p) / 2, d[ok])
    hi = stats.chi2.ppf((1 + p) / 2, d[ok])
    assert res.fraction_in_pointwise == pytest.approx(((v[ok] >= lo) & (v[ok] <= hi)).mean())
    assert 1.0 <= res.n_effective <= res.n_samples or res.n_samples < 3
    assert res.inside == (res.bounds[0] <= res.mean <= res.bounds[1])


@FAST
@given(v=st.floats(-3, 3).filter(lambda a: abs(a) > 0.06), w=st.floats(-0.5, 0.5),
       s1=st.floats(-0.94, 0.94), s2=st.floats(-0.94, 0.94))
def test_slip_model_rim_rows_give_back_the_state_slip_as_sae_slip(v, w, s1, s2):
    """Each wheel row is the rim speed whose SAE slip (seed 001 eqs. 7.1-7.2, denominator
    eq. 7.7, terrain.terramechanics.slip.sae_slip) over the side's ground speed
    g = v -+ chi B w / 2 is the state's slip, forward or reverse; driving forward a positive
    slip (traction) makes the rim the faster, a negative one (braking) the slower."""
    from terrain.estimation.skid_steer_slip import SkidSteerSlipModel
    from terrain.terramechanics.slip import sae_slip
    model = SkidSteerSlipModel()
    lc = np.log(1.4)
    x = np.array([v, w, 0.0, lc, s1, s2, 0.0, 0.0])
    hx = model.h(x)
    half = 1.4 * TRACK_M * w / 2
    for rim, g, s in ((hx[0], v - half, s1), (hx[1], v + half, s2)):
        if abs(g) < 1e-3:
            continue
        assert sae_slip(rim, g, dead_band_m_s=0.0) == pytest.approx(s, abs=1e-9)
        if g > 0:
            assert (rim > g) == (s > 0) or abs(s) < 1e-12


@pytest.mark.parametrize("column", [True, 1.0, np.float64(0.0), "1"])
def test_an_angle_column_that_is_not_an_integer_is_a_shape_error_naming_it(column):
    """state_errors(..., angle_columns=(True,)) wrapped column 1 without a word and (1.0,)
    stopped on numpy's bare IndexError ('only integers, slices ...')."""
    from terrain.errors import ShapeError
    from terrain.estimation.consistency import state_errors
    with pytest.raises(ShapeError, match="angle_columns"):
        state_errors(np.zeros((2, 2)), np.ones((2, 2)), (column,))
    e = state_errors(np.zeros((2, 2)), np.full((2, 2), 4.0), (np.int64(1),))
    np.testing.assert_allclose(e, [[-4.0, 2 * np.pi - 4.0]] * 2)


def test_boolean_windows_are_refused_not_read_as_speeds_of_0_and_1():
    """skid_steer_on_windows(np.ones((1, 3, 5), bool), 100.0) ran the filter on speeds of
    1 m/s and a yaw rate of 1 rad/s (final yaw rate estimate 0.96 rad/s)."""
    from terrain.errors import ShapeError
    from terrain.estimation.skid_steer import skid_steer_on_windows
    with pytest.raises(ShapeError, match="booleans"):
        skid_steer_on_windows(np.ones((1, 3, 5), bool), 100.0)
    x = skid_steer_on_windows(np.ones((1, 3, 5)), 100.0)[0]
    assert x.shape == (1, 5, 4)


def test_an_equality_bound_is_never_released_and_moves_the_correlated_state():
    """lower == upper on state 0 (an equality) with x0 below it: its multiplier has the sign
    of a lower bound while the state is held at a bound equal to its upper one; releasing it
    cycled until the clip, which left the correlated state 1 where it was. The projection
    is x - P[:, 0] (x0 - 0) / P00 (Simon & Chia 2002 eq. 13)."""
    from terrain.estimation.ekf import project_to_bounds
    P = np.array([[1.0, 0.6], [0.6, 1.0]])
    x = np.array([-1.0, 0.5])
    xc, active = project_to_bounds(x, P, np.array([0.0, -np.inf]), np.array([0.0, np.inf]))
    np.testing.assert_allclose(xc, [0.0, 0.5 + 0.6], rtol=1e-12)
    assert active.tolist() == [True, False]


@FAST
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 60), kind=st.sampled_from(
    ["ramp", "noise", "walk", "const", "alt"]))
def test_effective_sample_size_is_between_one_and_the_count_of_finite_values(seed, n, kind):
    """N / tau clipped to [1, N] (a short ramp has tau > N: its few samples still count as
    one); non-finite values are dropped first."""
    from terrain.estimation.consistency import effective_sample_size
    rng = np.random.default_rng(seed)
    x = {"ramp": np.arange(n, dtype=float), "noise": rng.normal(size=n),
         "walk": np.cumsum(rng.normal(size=n)), "const": np.full(n, 2.0),
         "alt": (-1.0) ** np.arange(n)}[kind]
    x[rng.uniform(size=n) < 0.1] = np.nan
    k = int(np.isfinite(x).sum())
    ess = effective_sample_size(x)
    assert 1.0 <= ess <= max(k, 1)


def test_a_non_finite_drift_std_falls_back_to_the_window_pseudo_std():
    """drift_std NaN at a window: that segment's slip drift is slip_psd + slip_psd_rel
    pseudo_std^2 (documented fallback), the same run as with drift_std = pseudo_std there;
    not slip_psd alone."""
    from terrain.estimation.skid_steer_slip import SkidSteerSlipSettings
    t, s = _slip_samples(3)
    tp = np.array([0.5, 1.0, 1.5, 2.0])
    sp = np.full((4, 2), 0.1)
    sd = np.array([0.05, 0.2, 0.1, 0.3])
    cfg = SkidSteerSlipSettings(slip_psd_rel=5.0)
    drift = np.array([0.1, np.nan, 0.2, np.nan])
    a = run_with_pseudo_slip(t, s, cfg, tp, sp, sd, drift_std=drift)
    filled = np.where(np.isfinite(drift), drift, sd)
    b = run_with_pseudo_slip(t, s, cfg, tp, sp, sd, drift_std=filled)
    np.testing.assert_array_equal(a.x, b.x)
    c = run_with_pseudo_slip(t, s, cfg, tp, sp, sd, drift_std=np.nan_to_num(drift))
    assert np.abs(c.P_diag[:, 4] - a.P_diag[:, 4]).max() > 1e-6


@pytest.mark.parametrize("ratio", [2.5, 4.0])
def test_an_observer_step_over_twice_the_median_is_corrected_over_one_median_step(ratio):
    """Module docstring of terrain.estimation.observer: a step longer than twice the median
    one is a gap; the correction of the sample before it is integrated over one median step
    h and the rest is predicted with e = 0 (eq. 8, yaw-only: theta' = w_g(eta) + l3 e)."""
    import math

    from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer
    h = 0.01
    t = np.array([0.0, h, 2 * h, 2 * h + ratio * h])
    vr, vl = np.array([1.0, 1.0, 1.1, 1.0]), np.array([0.6, 0.6, 0.5, 0.6])
    theta = np.array([0.0, 0.004, 0.01, 0.02])
    pose = np.column_stack([np.full(4, np.nan), np.full(4, np.nan), theta])
    cfg = AdaptiveObserverSettings(use_position=False)
    res = run_adaptive_observer(t, pose, vr, vl, cfg)
    d, l3, lam = cfg.half_track_m, cfg.l_gains[2], cfg.lambda_gains
    er, el = res.eta[2]
    e = res.error[2, 2]
    w = (vr[2] * er - vl[2] * el) / (2 * d)
    th = res.pose_hat[2, 2] + h * (w + l3 * e)
    er1 = min(max(er + h * lam[0] * vr[2] / (2 * d) * e, 0.02), 2.0)
    el1 = min(max(el - h * lam[1] * vl[2] / (2 * d) * e, 0.02), 2.0)
    rest = (ratio - 1.0) * h
    th += rest * (vr[2] * er1 - vl[2] * el1) / (2 * d)
    np.testing.assert_allclose(res.eta[3], [er1, el1], rtol=1e-12)
    assert res.pose_hat[3, 2] == pytest.approx(th, rel=1e-12, abs=1e-15)
    assert math.isfinite(res.error[3, 2])


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), engine=st.sampled_from(["numpy", "numba"]))
def test_a_skid_steer_run_in_millimetres_is_the_run_in_metres_scaled(seed, engine):
    """Every length in mm (speeds, track, wheel noise, speed prior, acceleration density in
    mm^2): v_bx and its std scale by 1000; yaw rate, bias, ln(chi) and the NIS are the
    same (no hidden constant in metres)."""
    from terrain.estimation.runner import run_filter
    from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
    t, wheels, gyro = _skid_run(seed)
    m = SkidSteerSettings(chi0=1.4)
    mm = SkidSteerSettings(chi0=1.4, track_m=m.track_m * 1e3, wheel_std_m_s=m.wheel_std_m_s
                           * 1e3, accel_psd=m.accel_psd * 1e6, v0_std=m.v0_std * 1e3)
    gy = SensorSamples(t, gyro[:, None])
    a = run_filter(SkidSteerModel(m), t, {"wheels": SensorSamples(t, wheels), "gyro": gy},
                   engine=engine)
    b = run_filter(SkidSteerModel(mm), t, {"wheels": SensorSamples(t, wheels * 1e3),
                                           "gyro": gy}, engine=engine)
    np.testing.assert_allclose(b.x, a.x * [1e3, 1, 1, 1], rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(b.P_diag, a.P_diag * [1e6, 1, 1, 1], rtol=1e-8, atol=1e-15)
    np.testing.assert_allclose(b.nis, a.nis, rtol=1e-8)


@FAST
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 8), rows=st.integers(1, 3))
def test_autocorrelation_time_of_a_row_holding_a_non_finite_value_is_nan_at_any_length(
        seed, n, rows):
    """Documented: NaN for a row holding a non-finite value, whatever its length; a row of
    fewer than 3 samples gave 1 (independent samples) even with a NaN in it:
    integrated_autocorrelation_time([nan, 1.0]) was 1.0 (with 3 samples NaN)."""
    from terrain.estimation.consistency import integrated_autocorrelation_time
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(rows, n))
    x[rng.uniform(size=x.shape) < 0.3] = rng.choice([np.nan, np.inf, -np.inf])
    tau = integrated_autocorrelation_time(x)
    assert tau.shape == (rows,)
    bad = ~np.isfinite(x).all(axis=1)
    assert np.isnan(tau[bad]).all()
    assert (tau[~bad] >= 1.0).all()
    if n < 3:
        assert (tau[~bad] == 1.0).all()


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), at=st.lists(st.integers(0, 150), min_size=1,
                                                   max_size=5, unique=True))
def test_a_segmented_run_reports_the_rate_and_step_count_of_its_whole_grid(seed, at):
    """meta of run_with_pseudo_slip: n_steps and rate_hz of the whole grid, wherever the
    pseudo-measurements cut it; one on the first step (a first segment of one step) gave
    rate_hz NaN."""
    t, s = _slip_samples(seed)
    tp = t[np.sort(at)]
    res = run_with_pseudo_slip(t, s, pseudo_t_s=tp, pseudo_slip=np.full((tp.size, 2), 0.1),
                               pseudo_std=np.full(tp.size, 0.1))
    assert res.meta["n_steps"] == t.size
    assert res.meta["rate_hz"] == pytest.approx(50.0, rel=1e-9)
    np.testing.assert_array_equal(res.t_s, t)


@pytest.mark.parametrize("values, columns", [(5.0, ()), (np.ones((3, 2, 2)), ()),
                                             (np.ones((3, 2)), (0.5,)),
                                             (np.ones((3, 2)), (True,))])
def test_ema_input_of_another_shape_or_a_non_integer_angle_column_is_an_estimation_error(
        values, columns):
    """ema_filter(5.0, 0.5) and angle_columns=(0.5,) stopped on numpy's bare IndexError;
    a (3, 2, 2) array was filtered as one column; True was taken as column 1."""
    from terrain.errors import EstimationError
    from terrain.estimation.prefilter import ema_filter
    with pytest.raises(EstimationError, match="EMA"):
        ema_filter(values, 0.5, columns)
    np.testing.assert_allclose(ema_filter(np.ones((3, 2)), 0.5, (np.int64(1),)), 1.0)


def test_projection_with_two_nearly_collinear_active_states_still_projects():
    """Two violated states correlated at 0.9999 (cond(P_aa) 2e4, far below the 1e12 at
    which the projection gives up for a clip): the third, free state moves by
    -P_fa P_aa^-1 (x_a - d) (Simon & Chia 2002 eq. 13), not left where a clip leaves it."""
    from terrain.estimation.ekf import project_to_bounds
    P = np.array([[1.0, 0.9999, 0.5], [0.9999, 1.0, 0.5], [0.5, 0.5, 1.0]])
    assert np.linalg.eigvalsh(P)[0] > 0
    x = np.array([2.0, 2.0, 0.0])
    lo, up = np.array([-1.0, -1.0, -np.inf]), np.array([1.0, 1.0, np.inf])
    xc, active = project_to_bounds(x, P, lo, up)
    lam = np.linalg.solve(P[:2, :2], x[:2] - 1.0)
    assert active.tolist() == [True, True, False]
    np.testing.assert_allclose(xc, [1.0, 1.0, -P[2, :2] @ lam], rtol=1e-9)
    assert xc[2] == pytest.approx(-0.50003, rel=1e-4)


@pytest.mark.parametrize("slip", [0.9, 0.93, 0.945, -0.93])
def test_slip_model_wheel_rows_keep_their_slip_column_just_inside_max_slip(slip):
    """Only |s| > MAX_SLIP (0.95) is clipped with no slip column: at 0.9 < |s| < 0.95 the
    column is d rim / d s of eqs. 7.1-7.2 (|g| / (1 - q)^2 in traction, |g| in braking)."""
    from terrain.estimation.model import finite_difference_jacobian
    from terrain.estimation.skid_steer_slip import SkidSteerSlipModel
    model = SkidSteerSlipModel()
    x = np.array([1.0, 0.3, 0.0, np.log(1.4), slip, -slip, 0.0, 0.0])
    hx, H = model.observation(x)
    half = 1.4 * TRACK_M * 0.3 / 2
    for i, (g, s) in enumerate(((1.0 - half, slip), (1.0 + half, -slip))):
        want = g / (1 - s) ** 2 if s >= 0 else g
        assert H[i, 4 + i] == pytest.approx(want, rel=1e-12)
    np.testing.assert_allclose(H, finite_difference_jacobian(model.h, x, eps=1e-7), rtol=1e-5,
                               atol=1e-6)


@pytest.mark.parametrize("column, values", [("vel_l", [True, False, True]),
                                            ("wz", ["0", "0", "0"]), ("vel_r", ["a", 1, 1]),
                                            ("t_s", [False, True, True])])
def test_a_non_numeric_column_of_an_aligned_frame_is_named(column, values):
    """skid_steer_on_frame read a boolean vel_l as speeds of 0 and 1 m/s and the text '0' as
    a number, and stopped on numpy's bare ValueError for 'a'."""
    import pandas as pd

    from terrain.errors import NonNumericError
    from terrain.estimation.skid_steer import skid_steer_on_frame
    frame = pd.DataFrame({"t_s": [0.0, 0.01, 0.02], "vel_l": [1.0] * 3, "vel_r": [1.0] * 3,
                          "wz": [0.0] * 3})
    assert np.isfinite(skid_steer_on_frame(frame).x).all()
    frame[column] = pd.Series(values, dtype=object if column != "vel_l" else bool)
    with pytest.raises(NonNumericError, match=column):
        skid_steer_on_frame(frame)


@pytest.mark.parametrize("kwargs", [{"half_track_m": -0.3}, {"half_track_m": np.nan},
                                    {"half_track_m": 0.0}, {"half_track_m": True},
                                    {"half_track_m": 0.3, "min_speed_m_s": np.nan},
                                    {"half_track_m": 0.3, "min_speed_m_s": -1.0}])
def test_eta_from_truth_refuses_a_track_or_speed_floor_that_is_not_a_length(kwargs):
    """A NaN half track or speed floor gave eta NaN everywhere and a negative half track
    swapped the sides (eta_R 0.7 and eta_L 1.3 for 1.3 and 0.7), without a word."""
    from terrain.errors import ConfigError
    from terrain.estimation.observer import eta_from_truth
    ones = np.ones(2)
    with pytest.raises(ConfigError, match="eta_from_truth"):
        eta_from_truth(ones, ones, ones, ones, **kwargs)
    np.testing.assert_allclose(eta_from_truth(ones, ones, ones, ones, 0.3), [[1.3, 0.7]] * 2)


def test_consistency_statistics_refuse_booleans_where_numbers_are_meant():
    """chi2_test([True, False, True], 1) gave a mean NIS of 0.67, nees of a boolean error
    2.0 and state_errors of boolean estimates differences of 0 and 1, as if a mask were
    data."""
    from terrain.errors import EstimationError
    from terrain.estimation.consistency import chi2_test, nees, state_errors
    mask = np.array([True, False, True])
    with pytest.raises(EstimationError, match="chi2_test: values"):
        chi2_test(mask, 1)
    with pytest.raises(EstimationError, match="chi2_test: dof"):
        chi2_test(np.ones(3), mask)
    with pytest.raises(EstimationError, match="nees: errors"):
        nees(np.ones((1, 2), bool), np.eye(2)[None])
    with pytest.raises(EstimationError, match="state_errors: truth"):
        state_errors(np.zeros((2, 2)), np.ones((2, 2), bool))
    assert chi2_test(np.array([1.0, 0.5, 2.0]), np.array([1, 1, 2])).n_samples == 3


@pytest.mark.parametrize("threshold", [np.nan, np.inf, True, "0.05", None])
def test_an_autocorrelation_threshold_that_is_not_a_finite_number_is_refused(threshold):
    """threshold=NaN stopped the sum at the first lag without a word (tau 1 for an AR(1)
    series of tau 9)."""
    from scipy import signal

    from terrain.errors import ConfigError
    from terrain.estimation.consistency import integrated_autocorrelation_time
    ar = signal.lfilter([1.0], [1.0, -0.8], np.random.default_rng(5).standard_normal(5000))
    with pytest.raises(ConfigError, match="threshold"):
        integrated_autocorrelation_time(ar, 2000, threshold)
    assert integrated_autocorrelation_time(ar, 2000, 0.05) == pytest.approx(9.0, rel=0.2)


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), p_nan=st.floats(0.0, 0.6), gated=st.booleans(),
       yaw0=st.floats(-np.pi, np.pi))
def test_compiled_and_reference_agrimaro_loops_agree_on_random_gaps_and_wrapped_yaw(
        seed, p_nan, gated, yaw0):
    """The AgriMaRo EKF (12 states, 14 rows, two angle rows) on data drawn from its own
    model around a heading that crosses +-pi, rows missing at random, with or without a
    gate: the compiled loop equals the NumPy reference (states, variances, innovations,
    NIS, gate decisions)."""
    from terrain.estimation.agrimaro import AgriMaRoEKFSettings, AgriMaRoModel
    from terrain.estimation.ekf import Gate
    from terrain.estimation.runner import run_filter
    model = AgriMaRoModel(settings=AgriMaRoEKFSettings(q_diag=(1e-4,) * 12))
    rng = np.random.default_rng(seed)
    N, dt = 150, 0.01
    t = np.arange(N) * dt
    x = model.x0.copy()
    x[2], x[3], x[5] = yaw0, 0.4, 0.8
    Z = np.empty((N, model.n_measurements))
    for k in range(N):
        if k:
            x = model.f(x, dt) + rng.normal(size=12) * 1e-2
        z = model.h(x) + rng.normal(size=14) * np.sqrt(model.R_diag)
        z[[6, 13]] = (z[[6, 13]] + np.pi) % (2 * np.pi) - np.pi
        Z[k] = z
    Z[rng.uniform(size=Z.shape) < p_nan] = np.nan
    samples = {s: SensorSamples(t, Z[:, list(r)]) for s, r in model.sensor_rows.items()}
    gate = Gate(0.99) if gated else None
    a = run_filter(model, t, samples, gate=gate, engine="numpy")
    b = run_filter(model, t, samples, gate=gate, engine="numba")
    np.testing.assert_allclose(b.x, a.x, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(b.P_diag, a.P_diag, rtol=1e-8, atol=1e-14)
    np.testing.assert_allclose(b.y, a.y, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(b.nis, a.nis, rtol=1e-7, atol=1e-10)
    np.testing.assert_array_equal(b.accepted, a.accepted)
    assert a.counts == b.counts


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), engine=st.sampled_from(["numpy", "numba"]))
def test_sensor_nis_of_the_only_sensor_at_a_step_is_the_step_nis(seed, engine):
    """At steps where the gyro (one row) is the only sensor, its sensor_nis y^2 / S equals
    the step's NIS and the dof is 1; at steps with both sensors the dof is 3."""
    from terrain.estimation.runner import run_filter
    from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
    t, wheels, gyro = _skid_run(seed)
    res = run_filter(SkidSteerModel(SkidSteerSettings(chi0=1.4)), t,
                     {"wheels": SensorSamples(t[::4], wheels[::4]),
                      "gyro": SensorSamples(t, gyro[:, None])}, engine=engine)
    only = np.ones(t.size, bool)
    only[::4] = False
    np.testing.assert_allclose(res.sensor_nis("gyro")[only], res.nis[only], rtol=1e-12)
    assert (res.dof[only] == 1).all() and (res.dof[~only] == 3).all()


@pytest.mark.parametrize("which", ["pose", "v_right_m_s", "v_left_m_s"])
def test_the_adaptive_observer_refuses_booleans_for_a_pose_or_a_speed(which):
    """run_adaptive_observer ran on a boolean pose (a pose of 0 and 1 m / rad: eta 0.985)
    or boolean track speeds, as if a mask were data."""
    from terrain.errors import ShapeError
    from terrain.estimation.observer import run_adaptive_observer
    t = np.arange(5) * 0.01
    args = {"pose": np.zeros((5, 3)), "v_right_m_s": np.ones(5), "v_left_m_s": np.ones(5)}
    assert np.isfinite(run_adaptive_observer(t, **args).eta).all()
    args[which] = args[which].astype(bool)
    with pytest.raises(ShapeError, match=which):
        run_adaptive_observer(t, **args)
