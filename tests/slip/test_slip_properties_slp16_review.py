"""Review slp16: Hypothesis properties of terrain.slip against brute-force references and
physical invariants (slip definitions, mirror symmetry, lag recovery, dead reckoning,
evaluation tables)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import (ConfigError, EstimationError, NonFiniteInputError, ShapeError,
                            TimeStepError)
from terrain.slip.alignment import estimate_lag, gated_lag
from terrain.slip.baselines import (endo_turning_slip, fit_pitch_slip, pitch_slip,
                                    slip_ratio_as_sae)
from terrain.slip.core import sae_slip, skid_steer_side_slip, wheel_slip
from terrain.slip.evaluation import error_table, std_calibration_table
from terrain.slip.odometry import dead_reckon
from terrain.terramechanics.slip import ground_speed_from_slip

FAST = settings(max_examples=60, deadline=None)
SLOW = settings(max_examples=15, deadline=None)

speed = st.floats(-5.0, 5.0, allow_nan=False, allow_infinity=False)


def _sae_reference(w: float, v: float, dead_band: float = 0.05) -> float:
    """Seed 001 eqs. 7.1-7.2 written out case by case (ch. 7.2.1: clip to [-1, 1], 0 in the
    dead band and at 0/0)."""
    if abs(w) < dead_band and abs(v) < dead_band:
        return 0.0
    if w == 0.0 and v == 0.0:
        return 0.0
    if abs(w) >= abs(v):
        s = (w - v) / abs(w)     # eq. 7.1 (driving: the rim is the faster)
    else:
        s = (w - v) / abs(v)     # eq. 7.2 (braking: the ground is the faster)
    return min(max(s, -1.0), 1.0)


# --- slip definitions --------------------------------------------------------------------

@FAST
@given(w=speed, v=speed, band=st.sampled_from([0.0, 0.05, 0.3]))
def test_sae_slip_is_eq_7_1_when_driving_and_eq_7_2_when_braking(w, v, band):
    s = float(sae_slip(w, v, dead_band_m_s=band))
    assert s == pytest.approx(_sae_reference(w, v, band), abs=1e-12)
    assert -1.0 <= s <= 1.0


@FAST
@given(v=speed.filter(lambda x: x != 0.0), band=st.sampled_from([0.0, 0.05]))
def test_sae_slip_is_zero_at_pure_rolling_and_odd_under_reversal(v, band):
    assert float(sae_slip(v, v, dead_band_m_s=band)) == 0.0
    w = 1.3 * v
    assert float(sae_slip(-w, -v, dead_band_m_s=band)) == -float(
        sae_slip(w, v, dead_band_m_s=band))


@FAST
@given(w=st.floats(0.06, 5.0), q=st.floats(-0.94, 0.999), sign=st.sampled_from([1.0, -1.0]))
def test_ground_speed_from_slip_undoes_sae_slip(w, q, sign):
    rim = sign * w
    v = float(ground_speed_from_slip(rim, sign * q))
    assert float(sae_slip(rim, v, dead_band_m_s=0.0)) == pytest.approx(sign * q, abs=1e-9)


@FAST
@given(w=st.floats(-5.0, 5.0).filter(lambda x: abs(x) > 1e-3),
       alpha=st.floats(-3.0, 0.99))
def test_slip_ratio_as_sae_is_the_sae_slip_of_the_implied_ground_speed(w, alpha):
    v = w * (1.0 - alpha)
    s = float(slip_ratio_as_sae(w, alpha))
    assert s == pytest.approx(_sae_reference(w, v, 0.0), abs=1e-9)
    if w > 0 and 0.0 <= alpha < 1.0:     # forward traction: the two conventions agree
        assert s == pytest.approx(alpha, abs=1e-9)


# --- mirror symmetry and chunking --------------------------------------------------------

side = st.lists(st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(-2.0, 2.0),
                          st.floats(-3.0, 3.0)), min_size=1, max_size=30)


@FAST
@given(rows=side, track=st.floats(0.2, 2.0))
def test_skid_steer_side_slip_is_mirror_symmetric(rows, track):
    a = np.array(rows)
    rim, v, r = a[:, [0, 3]], a[:, 1], a[:, 2]
    s = skid_steer_side_slip(rim, v, r, track)
    mirrored = skid_steer_side_slip(rim[:, ::-1], v, -r, track)
    np.testing.assert_allclose(mirrored, s[:, ::-1], atol=1e-12)


@FAST
@given(rows=side, cut=st.integers(0, 30))
def test_wheel_slip_of_a_run_is_the_slip_of_its_chunks(rows, cut):
    a = np.array(rows)
    pos = np.array([[0.3, 0.25], [-0.4, -0.25]])
    rim = a[:, [0, 3]]
    whole = wheel_slip(rim, a[:, 1], a[:, 3] * 0.1, a[:, 2], pos)
    k = min(cut, len(a))
    parts = [wheel_slip(rim[sl], a[sl, 1], a[sl, 3] * 0.1, a[sl, 2], pos)
             for sl in (slice(0, k), slice(k, None))]
    np.testing.assert_array_equal(whole, np.vstack(parts))


# --- lag estimation -----------------------------------------------------------------------

def _lagged_pair(seed: int, lag_s: float, n: int = 1200, rate: float = 100.0) -> tuple:
    """``t`` (s, 100 Hz, 12 s), a smooth random signal on it and the same signal ``lag_s``
    late (read between its samples: any lag, whole samples or not)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n + 400) / rate
    x = np.cumsum(rng.standard_normal(t.size))
    kern = np.hanning(15)
    x = np.convolve(x, kern / kern.sum(), mode="same")
    tg = t[200:-200]
    return tg, np.interp(tg, t, x), np.interp(tg - lag_s, t, x)


@SLOW
@given(seed=st.integers(0, 10_000), lag_k=st.integers(-40, 40), shift=st.floats(-50.0, 1e4))
def test_estimate_lag_recovers_a_planted_integer_lag_wherever_the_clock_starts(
        seed, lag_k, shift):
    lag = lag_k / 100.0
    tg, ref, sig = _lagged_pair(seed, lag)
    est = estimate_lag(tg + shift, ref, tg + shift, sig, max_lag_s=0.6)
    assert est.lag_s == pytest.approx(lag, abs=0.011)
    assert est.correlation > 0.9


@SLOW
@given(seed=st.integers(0, 10_000), lag=st.floats(-0.35, 0.35))
def test_estimate_lag_recovers_a_sub_sample_lag(seed, lag):
    tg, ref, sig = _lagged_pair(seed, lag)
    est = estimate_lag(tg, ref, tg, sig, max_lag_s=0.5)
    assert est.lag_s == pytest.approx(lag, abs=0.006)


@SLOW
@given(seed=st.integers(0, 10_000), lag=st.floats(-0.3, 0.3))
def test_gated_lag_applies_a_clear_planted_lag_as_estimated(seed, lag):
    tg, ref, sig = _lagged_pair(seed, lag)
    est = gated_lag(tg, ref, tg, sig, max_lag_s=0.5)
    assert est.applied and est.reason == ""
    assert est == estimate_lag(tg, ref, tg, sig, max_lag_s=0.5)


@SLOW
@given(seed=st.integers(0, 10_000), lag_k=st.integers(-30, 30))
def test_estimate_lag_is_antisymmetric_in_its_two_signals(seed, lag_k):
    tg, ref, sig = _lagged_pair(seed, lag_k / 100.0)
    ab = estimate_lag(tg, ref, tg, sig, max_lag_s=0.5)
    ba = estimate_lag(tg, sig, tg, ref, max_lag_s=0.5)
    assert ab.lag_s == pytest.approx(-ba.lag_s, abs=1e-9)
    assert ab.correlation == pytest.approx(ba.correlation, abs=1e-9)


@FAST
@given(c=st.floats(-10.0, 10.0), n=st.integers(20, 400))
def test_estimate_lag_refuses_a_constant_signal(c, n):
    t = np.arange(n) / 100.0
    other = np.sin(7 * t)
    with pytest.raises(EstimationError, match="constant|too short"):
        estimate_lag(t, np.full(n, c), t, other, max_lag_s=0.05)
    with pytest.raises(EstimationError, match="constant|too short"):
        estimate_lag(t, other, t, np.full(n, c), max_lag_s=0.05)


@FAST
@given(n=st.integers(0, 19))
def test_estimate_lag_refuses_fewer_than_twenty_samples(n):
    t = np.arange(n) / 100.0
    with pytest.raises(EstimationError):
        estimate_lag(t, np.sin(t), t, np.cos(t), max_lag_s=0.02)


@FAST
@given(i=st.integers(1, 98), dup=st.booleans())
def test_estimate_lag_names_the_first_unsorted_time(i, dup):
    t = np.arange(100) / 100.0
    bad = t.copy()
    bad[i] = bad[i - 1] if dup else bad[i - 1] - 0.001
    with pytest.raises(TimeStepError, match=f"t_sig_s.*sample {i} "):
        estimate_lag(t, np.sin(9 * t), bad, np.sin(9 * t), max_lag_s=0.1)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -0.1, 0.0, True, "1"])
def test_estimate_lag_refuses_a_bad_range_or_rate_by_name(bad):
    t = np.arange(200) / 100.0
    with pytest.raises(ConfigError, match="max_lag_s"):
        estimate_lag(t, np.sin(t), t, np.sin(t), max_lag_s=bad)
    with pytest.raises(ConfigError, match="rate_hz"):
        estimate_lag(t, np.sin(t), t, np.sin(t), rate_hz=bad)


# --- dead reckoning -----------------------------------------------------------------------

@FAST
@given(v=st.floats(-3.0, 3.0), n=st.integers(2, 300), dt=st.floats(0.005, 0.2))
def test_dead_reckon_of_equal_sides_is_a_straight_line(v, n, dt):
    t = np.arange(n) * dt
    pose = dead_reckon(t, np.full(n, v), np.full(n, v), 0.55)
    np.testing.assert_allclose(pose[:, 0], v * t, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(pose[:, 1:], 0.0)


@FAST
@given(v=st.floats(0.1, 2.0), w=st.floats(-1.5, 1.5).filter(lambda x: abs(x) > 0.05),
       track=st.floats(0.3, 1.5))
def test_dead_reckon_at_constant_side_speeds_follows_the_circle(v, w, track):
    # v_R - v_L = w B, radius v / w: x = R sin(w t), y = R (1 - cos(w t))
    dt = 0.01
    t = np.arange(0.0, 6.0, dt)
    vl, vr = np.full(t.size, v - 0.5 * w * track), np.full(t.size, v + 0.5 * w * track)
    pose = dead_reckon(t, vl, vr, track)
    R = v / w
    np.testing.assert_allclose(pose[:, 2], w * t, atol=1e-9)
    # midpoint heading: chord error (v dt)(w dt)^2 / 24 per step at most
    tol = 6.0 / dt * v * dt * (w * dt) ** 2 / 24 + 1e-9
    np.testing.assert_allclose(pose[:, 0], R * np.sin(w * t), atol=tol)
    np.testing.assert_allclose(pose[:, 1], R * (1 - np.cos(w * t)), atol=tol)


trace = st.lists(st.tuples(st.floats(0.01, 0.3), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0),
                           st.floats(-0.3, 0.3)), min_size=2, max_size=40)


@FAST
@given(rows=trace, t0=st.floats(-100.0, 1e5), track=st.floats(0.3, 1.5))
def test_dead_reckon_is_mirror_symmetric_and_time_shift_invariant(rows, t0, track):
    a = np.array(rows)
    t = np.cumsum(a[:, 0])
    vl, vr, slip = a[:, 1], a[:, 2], a[:, 3]
    pose = dead_reckon(t, vl, vr, track, slip, -slip)
    shifted = dead_reckon(t + t0, vl, vr, track, slip, -slip)
    np.testing.assert_allclose(shifted, pose, atol=1e-6 * (1 + abs(t0)))
    mirrored = dead_reckon(t, vr, vl, track, -slip, slip)
    np.testing.assert_allclose(mirrored, pose * [1, -1, -1], atol=1e-12)


@FAST
@given(rows=trace.filter(lambda r: len(r) >= 3), frac=st.floats(0.0, 1.0),
       track=st.floats(0.3, 1.5))
def test_dead_reckon_of_a_run_is_its_chunks_composed(rows, frac, track):
    a = np.array(rows)
    cut = 1 + int(frac * (len(a) - 3))
    t = np.cumsum(a[:, 0])
    vl, vr = a[:, 1], a[:, 2]
    whole = dead_reckon(t, vl, vr, track)
    first = dead_reckon(t[:cut + 1], vl[:cut + 1], vr[:cut + 1], track)
    second = dead_reckon(t[cut:], vl[cut:], vr[cut:], track)
    x0, y0, h0 = first[-1]
    c, s = np.cos(h0), np.sin(h0)
    composed = np.column_stack([x0 + c * second[:, 0] - s * second[:, 1],
                                y0 + s * second[:, 0] + c * second[:, 1], h0 + second[:, 2]])
    np.testing.assert_allclose(composed, whole[cut:], atol=1e-9)


@pytest.mark.parametrize("name", ["v_left_m_s", "v_right_m_s", "slip_left", "lateral_m_s"])
@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_dead_reckon_names_the_non_finite_argument(name, bad):
    t = np.arange(5.0)
    args = {"v_left_m_s": np.ones(5), "v_right_m_s": np.ones(5), "slip_left": np.zeros(5),
            "lateral_m_s": np.zeros(5)}
    args[name] = args[name].copy()
    args[name][2] = bad
    with pytest.raises(NonFiniteInputError, match=name):
        dead_reckon(t, track_m=0.5, **args)


# --- endo baseline ------------------------------------------------------------------------

@FAST
@given(vl=st.floats(0.1, 2.0), vr=st.floats(0.1, 2.0), w=st.floats(-2.0, 2.0),
       track=st.floats(0.3, 1.5))
def test_endo_turning_slip_is_mirror_symmetric_and_closes_the_yaw_rate(vl, vr, w, track):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = endo_turning_slip(np.array([vl]), np.array([vr]), np.array([w]), track)
        m = endo_turning_slip(np.array([vr]), np.array([vl]), np.array([-w]), track)
    np.testing.assert_allclose(m, a[:, ::-1], atol=1e-9, equal_nan=True)
    al, ar = a[0]
    if np.isfinite(al) and abs(al) < 1 and abs(ar) < 1:
        assert track * w == pytest.approx(vr * (1 - ar) - vl * (1 - al), abs=1e-9)


# --- fits and tables ----------------------------------------------------------------------

@FAST
@given(rows=st.lists(st.tuples(st.floats(-0.3, 0.3), st.floats(-1.0, 1.0),
                               st.sampled_from(["ICE", "SAND"])), min_size=1, max_size=40),
       perm_seed=st.integers(0, 1000))
def test_fit_pitch_slip_is_per_terrain_least_squares_and_order_free(rows, perm_seed):
    p = np.array([r[0] for r in rows])
    s = np.array([r[1] for r in rows])
    lab = np.array([r[2] for r in rows], dtype=object)
    coef = fit_pitch_slip(p, s, lab)
    for name in set(lab):
        sel = lab == name
        a, b = coef[name]
        if np.ptp(p[sel]) < 0.01:
            assert (a, b) == (pytest.approx(s[sel].mean()), 0.0)
        else:
            A = np.column_stack([np.ones(sel.sum()), p[sel]])
            ref = np.linalg.lstsq(A, s[sel], rcond=None)[0]
            np.testing.assert_allclose([a, b], ref, atol=1e-7)
    perm = np.random.default_rng(perm_seed).permutation(len(p))
    again = fit_pitch_slip(p[perm], s[perm], lab[perm])
    for name in coef:
        np.testing.assert_allclose(again[name], coef[name], atol=1e-9)
    np.testing.assert_allclose(pitch_slip(coef, p[perm], lab[perm]),
                               pitch_slip(coef, p, lab)[perm])


table_rows = st.lists(st.tuples(st.sampled_from(["ICE", "SAND", "MUD"]),
                                st.sampled_from(["r1", "r2", "r3"]),
                                st.floats(-1, 1), st.floats(-1, 1),
                                st.one_of(st.floats(-1, 1), st.just(float("nan"))),
                                st.floats(-1, 1), st.booleans(),
                                st.floats(0.0, 0.5)), min_size=1, max_size=40)


@pytest.mark.slow
@FAST
@given(rows=table_rows)
def test_error_table_is_the_direct_numpy_median_and_p90(rows):
    meta = pd.DataFrame({"terrain": [r[0] for r in rows], "run_id": [r[1] for r in rows]})
    pred = np.array([[r[2], r[3]] for r in rows])
    truth = np.array([[r[4], r[5]] for r in rows])
    mask = np.array([r[6] for r in rows])
    tab = error_table(pred, truth, meta, mask)
    assert list(tab["terrain"]) == sorted(set(meta["terrain"][mask]))
    for _, row in tab.iterrows():
        sel = mask & (meta["terrain"] == row["terrain"]).to_numpy()
        e = np.abs(pred[sel] - truth[sel]).T.ravel()
        e = e[np.isfinite(e)]
        assert row["n_windows"] == sel.sum()
        assert row["n_scored"] == e.size
        assert row["n_runs"] == meta["run_id"][sel].nunique()
        if e.size:
            assert row["median_abs_err"] == pytest.approx(np.median(e))
            assert row["p90_abs_err"] == pytest.approx(np.percentile(e, 90))
        else:
            assert np.isnan(row["median_abs_err"])


@FAST
@given(rows=table_rows)
def test_std_calibration_coverage_is_the_direct_fraction_within_k_std(rows):
    meta = pd.DataFrame({"scenario": [r[0] for r in rows], "run_id": [r[1] for r in rows]})
    pred = np.array([[r[2], r[3]] for r in rows])
    truth = np.array([[r[4], r[5]] for r in rows])
    std = np.array([[r[7], 0.5 * r[7] + 0.01] for r in rows])
    mask = np.array([r[6] for r in rows])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tab = std_calibration_table(pred, std, truth, meta, mask)
    assert sorted(tab["scenario"]) == sorted(set(meta["scenario"][mask]))
    for _, row in tab.iterrows():
        sel = mask & (meta["scenario"] == row["scenario"]).to_numpy()
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            u = (np.abs(pred[sel] - truth[sel]) / std[sel]).ravel()
        f = u[~np.isnan(u)]
        assert row["n_windows"] == sel.sum()
        assert row["n_scored"] == f.size
        if f.size:
            assert row["coverage_1std"] == pytest.approx(np.mean(f <= 1))
            assert row["coverage_2std"] == pytest.approx(np.mean(f <= 2))


def test_shape_errors_are_typed():
    with pytest.raises(ShapeError):
        wheel_slip(np.zeros((3, 2)), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros((3, 2)))
    with pytest.raises(ShapeError):
        dead_reckon(np.arange(3.0), np.ones(3), np.ones(4), 0.5)
    with pytest.raises(ShapeError):
        dead_reckon(np.zeros(0), np.zeros(0), np.zeros(0), 0.5)


# --- physics slip and learned regressor ---------------------------------------------------

@SLOW
@given(seed=st.integers(0, 10_000), n=st.integers(1, 12), cut=st.floats(0.0, 1.0))
def test_physics_slip_is_mirror_symmetric_odd_in_travel_and_row_by_row(seed, n, cut):
    from terrain.slip.physics import physics_slip
    from terrain.vehicles import get_vehicle
    veh = get_vehicle("husky")
    rng = np.random.default_rng(seed)
    cur = rng.uniform(0.0, 25.0, (n, 2))
    rim = rng.uniform(0.05, 2.0, (n, 2))
    pitch = rng.uniform(-0.2, 0.2, n)
    probs = {"SNOW": rng.uniform(0.0, 1.0, n), "ICE": 0.3}
    a = physics_slip(veh, probs, cur, rim, pitch)
    # left/right swapped: the (symmetric) Husky's sides swap
    b = physics_slip(veh, probs, cur[:, ::-1], rim[:, ::-1], pitch)
    for f in a._fields:
        np.testing.assert_array_equal(getattr(b, f), getattr(a, f)[:, ::-1])
    # driving backwards: slip, traction and the interval change sign
    c = physics_slip(veh, probs, cur, -rim, pitch)
    np.testing.assert_allclose(c.slip, -a.slip, atol=1e-12)
    np.testing.assert_allclose(c.mu, -a.mu, atol=1e-12)
    np.testing.assert_allclose(c.std, a.std, atol=1e-12)
    np.testing.assert_allclose(c.lower, -a.upper, atol=1e-12)
    # rows are independent: the first k rows alone give their part of the whole
    k = int(cut * n)
    if k:
        d = physics_slip(veh, {"SNOW": probs["SNOW"][:k], "ICE": 0.3}, cur[:k], rim[:k],
                         pitch[:k])
        for f in a._fields:
            np.testing.assert_array_equal(getattr(d, f), getattr(a, f)[:k])
    assert np.all((a.lower <= a.slip + 1e-12) & (a.slip <= a.upper + 1e-12))
    assert np.all(np.abs(a.slip) <= 1.0) and np.all(a.std >= 0.0)


@pytest.mark.slow
@settings(max_examples=3, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_slip_regressor_does_not_depend_on_the_order_of_its_training_windows(seed):
    from terrain.slip.learned import SlipRegressor
    rng = np.random.default_rng(seed)
    n = 160
    X = rng.normal(size=(n, 3))
    y = np.column_stack([0.1 * X[:, 0], 0.1 * X[:, 1] ** 2,
                         np.where(X[:, 2] > 0, 1.5 + X[:, 2], np.nan), 0.01 * X[:, 0]])
    groups = np.repeat(np.arange(8), 20)
    perm = rng.permutation(n)
    a = SlipRegressor(max_iter=15, min_samples_leaf=5).fit(X, y, groups)
    b = SlipRegressor(max_iter=15, min_samples_leaf=5).fit(X[perm], y[perm], groups[perm])
    Xt = rng.normal(size=(40, 3))
    np.testing.assert_allclose(b.predict(Xt), a.predict(Xt), atol=1e-9)
    np.testing.assert_allclose(b.predict_std(Xt), a.predict_std(Xt), rtol=1e-9)
    # and its predictions are row by row
    np.testing.assert_array_equal(a.predict(Xt[::-1]), a.predict(Xt)[::-1])


# --- typed refusals -----------------------------------------------------------------------

_META3 = pd.DataFrame({"terrain": ["A", "B", "A"], "scenario": ["x", "x", "y"],
                       "run_id": ["r1", "r2", "r1"]})


@pytest.mark.parametrize("which", ["pred", "truth"])
@pytest.mark.parametrize("shape", [(3, 1), (3,), (2, 2), (4, 2)])
def test_error_table_refuses_predictions_that_are_not_two_sides_per_window(which, shape):
    # a one-column prediction was broadcast onto both sides and scored twice (n_scored 4
    # for the 2 windows of terrain A); a row count other than meta's was a bare numpy error
    arrays = {"pred": np.zeros((3, 2)), "truth": np.zeros((3, 2))}
    arrays[which] = np.zeros(shape)
    with pytest.raises(ShapeError, match=f"error_table: {which}"):
        error_table(arrays["pred"], arrays["truth"], _META3, np.ones(3, bool))


@pytest.mark.parametrize("which", ["pred", "std", "truth"])
@pytest.mark.parametrize("shape", [(3, 1), (2, 2), (4, 2)])
def test_std_calibration_table_refuses_arrays_that_are_not_two_sides_per_window(which, shape):
    arrays = {"pred": np.zeros((3, 2)), "std": np.ones((3, 2)), "truth": np.zeros((3, 2))}
    arrays[which] = np.zeros(shape)
    with pytest.raises(ShapeError, match=f"std_calibration_table: {which}"):
        std_calibration_table(arrays["pred"], arrays["std"], arrays["truth"], _META3,
                              np.ones(3, bool))


def test_error_tables_take_the_first_two_columns_of_wider_predictions():
    pred = np.array([[0.1, 0.2, 9.0, 9.0]] * 3)
    tab = error_table(pred, np.zeros((3, 2)), _META3, np.ones(3, bool))
    assert list(tab["n_scored"]) == [4, 2]
    assert tab["median_abs_err"].iloc[1] == pytest.approx(0.15)


_T = np.arange(200) / 100.0


@pytest.mark.parametrize("which", ["ref", "sig"])
@pytest.mark.parametrize("n_finite", [0, 5, 19])
def test_estimate_lag_names_the_signal_with_too_few_finite_samples(which, n_finite):
    # "fewer than 20 finite samples" named neither signal
    x = np.full(_T.size, np.nan)
    x[:n_finite] = np.sin(9 * _T[:n_finite])
    args = {"ref": np.sin(9 * _T), "sig": np.sin(9 * _T)}
    args[which] = x
    with pytest.raises(EstimationError,
                       match=rf"fewer than 20 finite samples in {which} \({n_finite} of"):
        estimate_lag(_T, args["ref"], _T, args["sig"], max_lag_s=0.1)


@pytest.mark.parametrize("which", ["ref", "sig"])
def test_estimate_lag_names_the_constant_signal(which):
    # "a signal is constant" did not say which one (a stuck encoder or a frozen camera?)
    args = {"ref": np.sin(9 * _T), "sig": np.sin(9 * _T)}
    args[which] = np.full(_T.size, 0.7)
    with pytest.raises(EstimationError, match=f"{which} is constant"):
        estimate_lag(_T, args["ref"], _T, args["sig"], max_lag_s=0.1)
    with pytest.raises(EstimationError, match=f"{which} is constant"):
        gated_lag(_T, args["ref"], _T, args["sig"], max_lag_s=0.1)


def test_estimate_lag_refuses_two_dimensional_series_as_a_shape_error():
    with pytest.raises(ShapeError, match="t_ref_s, ref"):
        estimate_lag(_T[:, None], _T[:, None], _T, _T, max_lag_s=0.1)


@pytest.mark.parametrize("t, first, kind", [
    ([0.0, 1.0, 2.0, 1.5, 3.0], 3, "before"),
    ([0.0, 1.0, 1.0, 2.0, 3.0], 2, "not after"),
    ([0.0, np.nan, 2.0, 3.0, 4.0], 1, "not finite"),
    ([0.0, 1.0, 2.0, 3.0, np.inf], 4, "not finite")])
def test_dead_reckon_names_the_first_time_out_of_order(t, first, kind):
    # "times must be finite and strictly increasing" said neither which sample nor how many
    with pytest.raises(TimeStepError, match=rf"t_s sample {first} \(.*\) is {kind}.*1 such"):
        dead_reckon(np.array(t), np.ones(5), np.ones(5), 0.5)


@pytest.mark.parametrize("name", ["t_s", "v_left_m_s", "v_right_m_s", "slip_left", "slip_right",
                                  "chi", "lateral_m_s", "yaw_rate_rad_s"])
def test_dead_reckon_refuses_booleans_by_name(name):
    # a boolean mask passed for a speed was integrated as 1 m/s (5 samples: x = 4 m)
    args = {"t_s": np.arange(5.0), "v_left_m_s": np.ones(5), "v_right_m_s": np.ones(5),
            "track_m": 0.5}
    args[name] = np.ones(5, dtype=bool) if name != "t_s" else np.array([0, 1] * 2 + [0], bool)
    with pytest.raises(EstimationError, match=f"dead_reckon: {name} must hold numbers"):
        dead_reckon(**args)
    if name in ("chi", "lateral_m_s", "slip_left"):
        args[name] = True
        with pytest.raises(EstimationError, match=f"dead_reckon: {name} must hold numbers"):
            dead_reckon(**args)


@pytest.mark.parametrize("name", ["t_ref_s", "ref", "t_sig_s", "sig"])
def test_estimate_lag_refuses_booleans_by_name(name):
    # a thresholded (boolean) speed was cross-correlated as 0/1 steps and a lag returned
    args = {"t_ref_s": _T, "ref": np.sin(9 * _T), "t_sig_s": _T, "sig": np.sin(9 * _T)}
    args[name] = args[name] > 0.5
    with pytest.raises(EstimationError, match=f"{name} must hold numbers"):
        estimate_lag(**args, max_lag_s=0.1)
    with pytest.raises(EstimationError, match=f"{name} must hold numbers"):
        gated_lag(**args, max_lag_s=0.1)


@pytest.mark.parametrize("name", ["rim_speed_m_s", "v_bx_m_s", "v_by_m_s", "yaw_rate_rad_s",
                                  "positions_m", "delta_rad"])
def test_wheel_slip_refuses_booleans_by_name(name):
    # a boolean rim speed was a slip against 1 m/s
    args = {"rim_speed_m_s": np.ones((4, 2)), "v_bx_m_s": np.ones(4), "v_by_m_s": np.zeros(4),
            "yaw_rate_rad_s": np.zeros(4), "positions_m": np.array([[0.0, 0.3], [0.0, -0.3]]),
            "delta_rad": np.zeros((4, 2))}
    args[name] = np.ones(np.shape(args[name]), dtype=bool)
    with pytest.raises(EstimationError, match=f"{name} must hold numbers"):
        wheel_slip(**args)


@pytest.mark.parametrize("name", ["rim_speed_m_s", "v_bx_m_s", "yaw_rate_rad_s"])
def test_skid_steer_side_slip_refuses_booleans_by_name(name):
    args = {"rim_speed_m_s": np.ones((4, 2)), "v_bx_m_s": np.ones(4),
            "yaw_rate_rad_s": np.zeros(4)}
    args[name] = np.ones(np.shape(args[name]), dtype=bool)
    with pytest.raises(EstimationError, match=f"{name} must hold numbers"):
        skid_steer_side_slip(**args, track_m=0.55)


def test_fit_predict_refuses_targets_of_another_length():
    # Y of 5 rows for 6 windows was a bare numpy IndexError ('boolean index did not match')
    from sklearn.linear_model import LinearRegression

    from terrain.slip.evaluation import fit_predict
    X = pd.DataFrame({"a": np.arange(6.0)})
    train = np.array([1, 1, 1, 0, 0, 0], bool)
    with pytest.raises(ShapeError, match=r"fit_predict: Y must have one row per window of X "
                                         r"\(6\), got shape \(5, 2\)"):
        fit_predict(LinearRegression, X, np.zeros((5, 2)), train, ~train)


_TRAIN = np.array([1, 1, 1, 0, 0, 0], bool)


@pytest.mark.parametrize("groups, train, test, match", [
    (list("aabbc"), _TRAIN, ~_TRAIN, "groups must have shape"),
    (list("aabbcc"), _TRAIN, (~_TRAIN).astype(int), "test must be a boolean mask"),
])
def test_leave_one_out_refuses_groups_or_masks_not_one_per_window(groups, train, test, match):
    # groups of 5 for 6 windows was a bare numpy IndexError; an integer 0/1 test mask picked
    # the groups of windows 0 and 1 before fit_predict saw it
    from sklearn.linear_model import LinearRegression

    from terrain.slip.evaluation import leave_one_out
    X = pd.DataFrame({"a": np.arange(6.0)})
    with pytest.raises(ShapeError, match=f"leave_one_out: {match}"):
        leave_one_out(LinearRegression, X, np.zeros((6, 2)), np.array(groups), train, test)


def _measured_X(n):
    return pd.DataFrame({"wz__mean": np.linspace(-0.3, 0.3, n), "vel_diff__mean": np.ones(n),
                         "cur_l__mean": np.ones(n), "cur_r__mean": np.ones(n),
                         "phys_slip_l": np.zeros(n), "phys_slip_r": np.zeros(n)})


@pytest.mark.parametrize("name, pred, run_ids, terrains", [
    ("pred", np.zeros((6, 2)), ["r"] * 6, ["A"] * 6),
    ("pred", np.ones((5, 4)), ["r"] * 6, ["A"] * 6),
    ("run_ids", np.ones((6, 4)), ["r"] * 4, ["A"] * 6),
    ("terrains", np.ones((6, 4)), ["r"] * 6, ["A"] * 5)])
def test_measured_checks_refuse_arrays_not_one_row_per_window(name, pred, run_ids, terrains):
    # each was a bare numpy IndexError/ValueError (pred without its chi column: 'index 2 is
    # out of bounds for axis 1 with size 2')
    from terrain.slip.evaluation import measured_checks
    with pytest.raises(ShapeError, match=f"measured_checks: {name} must have shape"):
        measured_checks(_measured_X(6), pred, np.array(run_ids), np.array(terrains), 0.55)


@pytest.mark.parametrize("shapes", [(5, 4, 5), (5, 5, 3)])
def test_endo_turning_slip_refuses_series_of_other_lengths(shapes):
    # a bare numpy 'operands could not be broadcast together' before
    vl, vr, w = (np.ones(k) for k in shapes)
    with pytest.raises(ShapeError, match="endo_turning_slip: v_left_m_s, v_right_m_s and "
                                         "yaw_rate_rad_s must share a shape"):
        endo_turning_slip(vl, vr, w, 0.5)


# --- pseudo-measurement fusion ------------------------------------------------------------

std_f = st.floats(1e-4, 0.5)
slip_f = st.floats(-1.0, 1.0)


@FAST
@given(rows=st.lists(st.tuples(slip_f, std_f, slip_f, std_f), min_size=1, max_size=20),
       rho=st.one_of(st.none(), st.floats(-1.0, 1.0)), floor=st.floats(1e-6, 0.01))
def test_fused_pseudo_measurement_is_the_inverse_variance_mean_of_its_two_models(
        rows, rho, floor):
    from terrain.slip.estimate import FusionSettings, pseudo_measurement
    a = np.array(rows)
    t = np.arange(len(a), dtype=float)
    sp, vp, sl, vl = (np.repeat(a[:, [k]], 2, axis=1) for k in range(4))
    outputs = {"physics": (t, sp, vp), "learned": (t, sl, vl)}
    fs = FusionSettings(min_std=floor, error_correlation=rho)
    tt, mean, std = pseudo_measurement(outputs, "fused", fs)
    np.testing.assert_array_equal(tt, t)
    vp, vl = np.maximum(vp, floor), np.maximum(vl, floor)
    wp, wl = vp ** -2, vl ** -2
    np.testing.assert_allclose(mean, (wp * sp + wl * sl) / (wp + wl), rtol=1e-12, atol=1e-15)
    assert np.all((mean >= np.minimum(sp, sl) - 1e-12) & (mean <= np.maximum(sp, sl) + 1e-12))
    if rho is None:
        np.testing.assert_array_equal(std, np.minimum(vp, vl))
    else:
        ap, al = wp / (wp + wl), wl / (wp + wl)
        ref = np.sqrt(ap ** 2 * vp ** 2 + al ** 2 * vl ** 2 + 2 * rho * ap * al * vp * vl)
        np.testing.assert_allclose(std, np.maximum(ref, floor), rtol=1e-9)
        if rho == 0.0:
            np.testing.assert_allclose(std, np.maximum((wp + wl) ** -0.5, floor), rtol=1e-9)
    # the two models enter alike: swapped, the same measurement
    swapped = pseudo_measurement({"physics": (t, sl, vl), "learned": (t, sp, vp)}, "fused", fs)
    np.testing.assert_allclose(swapped[1], mean, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(swapped[2], std, rtol=1e-12)
    # window by window: the first k windows alone give their part
    k = max(1, len(a) // 2)
    part = pseudo_measurement({n: tuple(x[:k] for x in v) for n, v in outputs.items()},
                              "fused", fs)
    np.testing.assert_array_equal(part[1], mean[:k])
    np.testing.assert_array_equal(part[2], std[:k])


@FAST
@given(v=st.floats(-2.0, 2.0).filter(lambda x: abs(x) > 1e-3), s=st.floats(-0.9, 0.99),
       n=st.integers(2, 50))
def test_slip_compensated_straight_line_is_the_ground_speed_of_the_sae_slip(v, s, n):
    # both sides at rim speed v with slip s (SAE, signed by travel): the body moves at the
    # ground speed that gives that slip (seed 001 eq. 7.1 traction, 7.2 braking)
    t = np.arange(n) * 0.1
    slip = np.full(n, s * np.sign(v))
    pose = dead_reckon(t, np.full(n, v), np.full(n, v), 0.55, slip, slip)
    ground = v * (1 - s) if s >= 0 else v / (1 + s)
    np.testing.assert_allclose(pose[:, 0], ground * t, rtol=1e-9, atol=1e-12)
    assert float(sae_slip(v, ground, dead_band_m_s=0.0)) == pytest.approx(s * np.sign(v))


def test_endo_turning_slip_is_defined_at_a_small_denominator():
    # v_r - rho v_l = 0.0098 m/s: above the guard against a division by ~0 (1e-6), so the
    # slips are defined (and close the measured yaw rate); a guard at 1e-2 made them NaN
    vl, vr = 0.004, 0.005
    rho = -(vr / vl) ** 0.847
    den = vr - rho * vl
    track, w = 0.059, (0.001 + 0.5 * den) / 0.059
    al, ar = endo_turning_slip(np.array([vl]), np.array([vr]), np.array([w]), track)[0]
    assert ar == pytest.approx(-0.5, abs=1e-9) and al == pytest.approx(rho * ar, abs=1e-9)
    assert track * w == pytest.approx(vr * (1 - ar) - vl * (1 - al), abs=1e-12)


def test_std_calibration_coverage_counts_an_error_of_exactly_k_std_as_covered():
    # |error| / std = 1.0 and 2.0 exactly: within 1 and 2 std ("<= k std", documented)
    meta = pd.DataFrame({"scenario": ["x"], "run_id": ["r"]})
    tab = std_calibration_table(np.array([[0.1, 0.2]]), np.array([[0.1, 0.1]]),
                                np.zeros((1, 2)), meta, np.ones(1, bool))
    assert tab["coverage_1std"].iloc[0] == 0.5
    assert tab["coverage_2std"].iloc[0] == 1.0


@FAST
@given(vals=st.lists(st.floats(-5, 5), min_size=3, max_size=30), dup=st.integers(1, 28))
def test_resample_is_np_interp_per_column_and_takes_a_repeated_time(vals, dup):
    # documented: only a time before the previous one (or not finite) is refused
    from terrain.slip.estimate import resample
    v = np.array(vals)
    t = np.arange(v.size, dtype=float)
    k = min(dup, v.size - 1)
    t[k] = t[k - 1]                      # a repeated time is not "before the previous one"
    grid = np.linspace(-1.0, v.size, 37)
    out = resample(grid, t, np.column_stack([v, -v]))
    ref = np.interp(grid, t, v, left=np.nan, right=np.nan)
    np.testing.assert_array_equal(out[:, 0], ref)
    np.testing.assert_array_equal(out[:, 1], -ref)


@FAST
@given(v=st.floats(0.2, 2.0), r=st.floats(-1.0, 1.0), track=st.floats(0.3, 1.5),
       rim=st.floats(0.1, 2.0))
def test_skid_steer_side_slip_moves_the_body_speed_to_the_side_contact_lines(v, r, track, rim):
    # left contact line at y = +B/2: v_long = v - r B / 2 (eq. 7.3), right at -B/2; a left
    # turn (r > 0) slows the left side (a swapped or full-track offset mirrors or doubles it)
    s = skid_steer_side_slip(np.full((1, 2), rim), np.array([v]), np.array([r]), track)[0]
    v_left, v_right = v - 0.5 * r * track, v + 0.5 * r * track
    assert s[0] == pytest.approx(_sae_reference(rim, v_left), abs=1e-12)
    assert s[1] == pytest.approx(_sae_reference(rim, v_right), abs=1e-12)
