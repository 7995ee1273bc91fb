"""Review slp32: held-out evaluation of slip models and slip-compensated odometry
(target shapes, std signs, measured checks' inputs, physical invariants of dead reckoning)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.linear_model import LinearRegression

from terrain.errors import (ConfigError, DataWarning, EstimationError, MissingColumnError,
                            ShapeError)
from terrain.run import Run
from terrain.slip.evaluation import (baseline_predictions, fit_predict, leave_one_out,
                                     measured_checks, observer_window_slip, odometry_errors,
                                     std_calibration_table, steady_straight)
from terrain.slip.estimate import FusionSettings, pseudo_measurement
from terrain.slip.learned import SlipRegressor, calibration_folds
from terrain.slip.odometry import dead_reckon

FAST = settings(max_examples=30, deadline=None)


@pytest.mark.slow
@FAST
@given(n_groups=st.integers(2, 4), per_group=st.integers(2, 4), seed=st.integers(0, 999))
def test_leave_one_out_of_one_target_per_window_is_one_prediction_per_window(
        n_groups, per_group, seed):
    """A single target per window (shape (n,), which fit_predict takes) gives one
    prediction per window as with the target as a column, not an (n, n) table."""
    rng = np.random.default_rng(seed)
    n = n_groups * per_group
    X = pd.DataFrame({"a": rng.normal(size=n), "b": rng.normal(size=n)})
    y = rng.normal(size=n)
    groups = np.repeat(np.arange(n_groups), per_group)
    train = np.arange(n) % per_group != 0
    test = ~train
    flat = leave_one_out(LinearRegression, X, y, groups, train, test)
    column = leave_one_out(LinearRegression, X, y[:, None], groups, train, test)
    assert flat.shape == (n,)
    np.testing.assert_array_equal(flat, column[:, 0])
    for g in range(n_groups):   # each group's prediction is the model of the others
        m = groups == g
        np.testing.assert_allclose(flat[test & m], fit_predict(
            LinearRegression, X, y, train & ~m, test & m)[test & m])


def _meta(n_runs: int, per_run: int) -> pd.DataFrame:
    rid = np.repeat([f"r{i}" for i in range(n_runs)], per_run)
    return pd.DataFrame({"run_id": rid, "terrain": "A", "scenario": "s",
                         "t_start_s": 0.0, "t_end_s": 2.0})


@FAST
@given(sign_at=st.integers(0, 5), side=st.integers(0, 1), value=st.floats(-10, -1e-9))
def test_std_calibration_table_refuses_a_negative_std_by_name(sign_at, side, value):
    """|error| / std of a negative std is negative, <= 1: the window was counted as covered
    whatever its error (coverage 1 of a model that is wrong everywhere)."""
    meta = _meta(2, 3)
    std = np.full((6, 2), 0.1)
    std[sign_at, side] = value
    with pytest.raises(EstimationError, match=r"std_calibration_table: std must be >= 0.*"
                       rf"1 of 6 windows \(window {sign_at}\)"):
        std_calibration_table(np.zeros((6, 2)), std, np.ones((6, 2)), meta, np.ones(6, bool))


@FAST
@given(k=st.floats(0.01, 100), seed=st.integers(0, 999))
def test_std_calibration_coverage_is_invariant_to_scaling_errors_and_std_together(k, seed):
    """Coverage and normalised errors are dimensionless: scaling errors and std by k moves
    neither; the median std and error scale by k; NaN stds are counted out (n_scored)."""
    rng = np.random.default_rng(seed)
    meta = _meta(3, 4)
    pred, truth = rng.normal(size=(12, 2)), rng.normal(size=(12, 2))
    std = rng.uniform(0.1, 2.0, size=(12, 2))
    std[rng.integers(12), rng.integers(2)] = np.nan
    mask = rng.random(12) < 0.8
    mask[0] = True
    a = std_calibration_table(pred, std, truth, meta, mask)
    b = std_calibration_table(k * pred, k * std, k * truth, meta, mask)
    for c in ("n_windows", "n_scored", "coverage_1std", "coverage_2std"):
        np.testing.assert_allclose(a[c], b[c])
    assert a["n_scored"].sum() == 2 * mask.sum() - np.isnan(std[mask]).sum()


_MEASURED = ("wz__mean", "vel_diff__mean", "cur_l__mean", "cur_r__mean", "phys_slip_l",
             "phys_slip_r")
_BASELINE = ("pitch", "vel_l__mean", "vel_r__mean", "wz__mean", "phys_slip_l", "phys_slip_r")


def _features(columns, n: int = 6) -> pd.DataFrame:
    rng = np.random.default_rng(1)
    return pd.DataFrame({c: rng.normal(size=n) for c in columns})


@pytest.mark.parametrize("column", _MEASURED)
def test_measured_checks_name_a_missing_feature_column(column):
    """A feature table without one of the columns read was a bare pandas KeyError."""
    X = _features(_MEASURED).drop(columns=column)
    with pytest.raises(MissingColumnError, match=rf"measured_checks: X has no feature "
                       rf"column\(s\) \['{column}'\]") as e:
        measured_checks(X, np.ones((6, 4)), np.array(list("aabbcc")), np.array(["x"] * 6), 0.5)
    assert e.value.column == column


@pytest.mark.parametrize("column", _BASELINE)
def test_baseline_predictions_name_a_missing_feature_column(column):
    X = _features(_BASELINE).drop(columns=column)
    meta = _meta(2, 3)
    with pytest.raises(MissingColumnError, match=rf"baseline_predictions: X has no feature "
                       rf"column\(s\) \['{column}'\]"):
        baseline_predictions(X, np.zeros((6, 4)), meta, np.ones(6, bool), [], 0.5)
    with pytest.raises(MissingColumnError, match=r"meta has no provenance column\(s\) "
                       r"\['terrain'\]"):
        baseline_predictions(_features(_BASELINE), np.zeros((6, 4)),
                             meta.drop(columns="terrain"), np.ones(6, bool), [], 0.5)


@pytest.mark.parametrize("column", ["scenario", "t_start_s"])
def test_steady_straight_names_a_missing_provenance_column(column):
    with pytest.raises(MissingColumnError, match=rf"steady_straight: meta has no provenance "
                       rf"column\(s\) \['{column}'\]"):
        steady_straight(_meta(2, 3).drop(columns=column), np.zeros(6))


def _drive(seed: int, n: int):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 0.2, size=n))
    vl, vr = rng.uniform(-2, 2, size=(2, n))
    return rng, t, vl, vr


def _path(pose: np.ndarray) -> float:
    return float(np.sum(np.hypot(*np.diff(pose[:, :2], axis=0).T)))


@FAST
@given(seed=st.integers(0, 9999), n=st.integers(1, 30), track=st.floats(0.2, 2.0))
def test_dead_reckon_with_zero_slip_is_plain_wheel_odometry(seed, n, track):
    """Slips of 0 (arrays or floats), chi 1 and no lateral velocity are plain odometry,
    bit for bit; the pose starts at 0."""
    _, t, vl, vr = _drive(seed, n)
    plain = dead_reckon(t, vl, vr, track)
    np.testing.assert_array_equal(plain[0], 0.0)
    np.testing.assert_array_equal(
        dead_reckon(t, vl, vr, track, np.zeros(n), np.zeros(n), np.ones(n), np.zeros(n)),
        plain)
    np.testing.assert_array_equal(dead_reckon(t, vl, vr, track, 0.0, 0.0, 1.0, 0.0), plain)


@FAST
@given(seed=st.integers(0, 9999), n=st.integers(1, 30), track=st.floats(0.2, 2.0),
       gyro=st.booleans())
def test_dead_reckon_mirrored_left_right_mirrors_the_pose(seed, n, track, gyro):
    """Swapping the sides (speeds and slips), the lateral velocity's and the gyro's sign
    mirrors the path about the start heading: x kept, y and yaw negated."""
    rng, t, vl, vr = _drive(seed, n)
    sl, sr = rng.uniform(-0.9, 0.9, size=(2, n))
    chi, vy, wz = rng.uniform(1, 3, size=n), rng.normal(0, 0.1, size=n), rng.normal(size=n)
    kw = {"yaw_rate_rad_s": wz} if gyro else {"chi": chi}
    kw_m = {"yaw_rate_rad_s": -wz} if gyro else {"chi": chi}
    pose = dead_reckon(t, vl, vr, track, sl, sr, lateral_m_s=vy, **kw)
    mirror = dead_reckon(t, vr, vl, track, sr, sl, lateral_m_s=-vy, **kw_m)
    np.testing.assert_allclose(mirror, pose * [1, -1, -1], atol=1e-9)


@FAST
@given(seed=st.integers(0, 9999), n=st.integers(2, 30), track=st.floats(0.2, 2.0))
def test_compensated_odometry_in_traction_never_claims_more_than_the_wheels_turned(
        seed, n, track):
    """A traction slip in [0, 1] (the rim turns faster than the ground passes) takes ground
    speed off each side: the compensated path is at most the mean distance the two sides'
    rims rolled, and driving forwards with equal slips on both sides at most the plain
    path."""
    rng, t, vl, vr = _drive(seed, n)
    sl, sr = rng.uniform(0, 1, size=(2, n))
    pose = dead_reckon(t, vl, vr, track, sl * np.sign(vl), sr * np.sign(vr))
    dt = np.diff(t)
    rolled = 0.5 * np.sum(dt * 0.5 * (np.abs(vl[:-1]) + np.abs(vl[1:])
                                      + np.abs(vr[:-1]) + np.abs(vr[1:])))
    assert _path(pose) <= rolled * (1 + 1e-9) + 1e-12
    # driving forwards (no reversal, whose trapezoid mixes the directions) on a straight
    forwards = (np.abs(vl), np.abs(vr))
    same = dead_reckon(t, *forwards, track, sl, sl, yaw_rate_rad_s=0 * t)
    plain = dead_reckon(t, *forwards, track, yaw_rate_rad_s=0 * t)
    assert _path(same) <= _path(plain) * (1 + 1e-9) + 1e-12


@FAST
@given(n=st.integers(1, 20), track=st.floats(0.2, 2.0), seed=st.integers(0, 999))
def test_dead_reckon_at_standstill_claims_no_motion_whatever_the_slip(n, track, seed):
    """Wheels that do not turn give no distance and no heading, whatever slip is claimed."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 0.2, size=n))
    z = np.zeros(n)
    sl, sr = rng.uniform(-0.9, 1.0, size=(2, n))
    np.testing.assert_array_equal(dead_reckon(t, z, z, track, sl, sr, rng.uniform(1, 3, n)),
                                  np.zeros((n, 3)))


@FAST
@given(c=st.floats(0.01, 1.0), w=st.floats(0.1, 1.0), n=st.integers(2, 20))
def test_lateral_velocity_is_to_the_left_of_the_heading(c, w, n):
    """Sliding sideways at v_y > 0 (to the left, body y) while turning left at w: the world
    velocity is R(yaw) (0, v_y), so x decreases and y increases (yaw in (0, pi/2])."""
    t = np.linspace(0, 0.5 * np.pi / w, n)
    z = np.zeros(n)
    pose = dead_reckon(t, z, z, 1.0, lateral_m_s=c, yaw_rate_rad_s=np.full(n, w))
    assert pose[-1, 0] < 0 < pose[-1, 1]
    np.testing.assert_allclose(pose[:, 2], w * t)


@pytest.mark.filterwarnings("ignore::terrain.errors.DataWarning")
@pytest.mark.parametrize("k", [4.0, 0.125])
def test_calibrated_std_scales_with_the_slip_targets(k):
    """Slip targets (and the std floor, the one slip-valued setting) scaled by k (a power
    of 2: exact in floating point) scale the predicted slip and its calibrated std, both
    moments, by k; the coverage of the calibration is unchanged."""
    rng = np.random.default_rng(3)
    n = 150
    X = rng.normal(size=(n, 3))
    y = np.column_stack([0.1 * X[:, 0] + 0.02 * rng.normal(size=n),
                         0.05 * X[:, 1] + 0.02 * rng.normal(size=n),
                         np.full(n, np.nan), 0.01 * rng.normal(size=n)])
    groups = np.repeat([f"run{i}" for i in range(5)], n // 5)

    def fitted(scale):
        return SlipRegressor(max_iter=5, min_samples_leaf=5, std_floor=0.0005 * scale).fit(
            X, y * [scale, scale, 1, 1], groups)

    a, b = fitted(1.0), fitted(k)
    assert np.isfinite(a.predict_std(X)).all() and a.calibration_["n_windows"] == n
    np.testing.assert_allclose(b.predict(X)[:, :2], k * a.predict(X)[:, :2], rtol=1e-9,
                               atol=1e-15)
    for moment in ("median", "variance"):
        np.testing.assert_allclose(b.predict_std(X, moment), k * a.predict_std(X, moment),
                                   rtol=1e-9)
    assert b.calibration_["coverage_1std"] == a.calibration_["coverage_1std"]


def _odometry_case(names=("sim/SNOW/turn/0", "sim/SAND/turn/1"), seed: int = 0):
    """Runs whose truth is compensated odometry of known slips, their windows and the
    window predictions (slip_1, slip_2, chi, v_by)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 8.0, 0.1)
    starts = np.arange(0.0, 6.0, 2.0)
    runs, metas, preds = [], [], []
    for name in names:
        vl, vr = np.full_like(t, rng.uniform(0.3, 1)), np.full_like(t, rng.uniform(0.3, 1))
        sl, sr = rng.uniform(0, 0.4, size=(2, 3))
        truth = dead_reckon(t, vl, vr, 0.55, np.interp(t, starts + 1, sl),
                            np.interp(t, starts + 1, sr))
        runs.append(Run(name, "sim", name.split("/")[1],
                        {"wheels": pd.DataFrame({"t_s": t, "vel_l": vl, "vel_r": vr}),
                         "truth": pd.DataFrame({"t_s": t, "x": truth[:, 0],
                                                "y": truth[:, 1]})}))
        metas.append(pd.DataFrame({"run_id": name, "t_start_s": starts,
                                   "t_end_s": starts + 2.0}))
        preds.append(np.column_stack([sl, sr, np.ones(3), np.zeros(3)]))
    return runs, pd.concat(metas, ignore_index=True), np.vstack(preds)


def test_odometry_errors_refuse_a_run_given_twice():
    """A run twice in run_ids gave its row twice (weighing it double in a mean of the
    table) without a word."""
    runs, meta, pred = _odometry_case()
    ids = [runs[0].run_id, runs[1].run_id, runs[0].run_id]
    with pytest.raises(ConfigError, match=r"odometry_errors: run\(s\) \['sim/SNOW/turn/0'\] "
                       "given more than once in run_ids"):
        odometry_errors(runs, meta, pred, 0.55, ids)


@pytest.mark.slow
@FAST
@given(seed=st.integers(0, 99), reverse=st.booleans())
def test_odometry_errors_do_not_depend_on_run_names_or_their_order(seed, reverse):
    """Renaming the runs (ids swapped between them) or giving them in another order moves
    every figure with its run and changes none."""
    runs, meta, pred = _odometry_case(seed=seed)
    a = odometry_errors(runs, meta, pred, 0.55, [r.run_id for r in runs])
    swap = ("sim/SNOW/turn/9", "sim/SAND/turn/8")      # same terrains, other ids
    runs2, meta2, pred2 = _odometry_case(swap, seed=seed)
    order = [1, 0] if reverse else [0, 1]
    b = odometry_errors([runs2[i] for i in order], meta2, pred2, 0.55,
                        [runs2[i].run_id for i in order])
    b = b.set_index(b["run_id"].map(dict(zip(swap, a["run_id"])))).loc[list(a["run_id"])]
    pd.testing.assert_frame_equal(a.drop(columns="run_id").reset_index(drop=True),
                                  b.drop(columns="run_id").reset_index(drop=True))
    assert (a["compensated_err_pct"] < 1e-6).all()


@pytest.mark.parametrize("column", ["run_id", "t_start_s", "t_end_s"])
@pytest.mark.parametrize("which", ["odometry_errors", "observer_window_slip"])
def test_window_provenance_without_a_column_is_named(column, which):
    """A meta without run_id or a window bound was pandas' bare KeyError."""
    runs, meta, pred = _odometry_case()
    meta = meta.drop(columns=column)
    call = ((lambda: odometry_errors(runs, meta, pred, 0.55, [runs[0].run_id]))
            if which == "odometry_errors" else
            (lambda: observer_window_slip(runs, meta, 0.55)))
    with pytest.raises(MissingColumnError, match=rf"{which}: meta has no provenance "
                       rf"column\(s\) \['{column}'\]"):
        call()


@FAST
@given(n=st.integers(4, 12), seed=st.integers(0, 999), data=st.data())
def test_measured_checks_count_and_say_the_windows_without_a_yaw_rate(n, seed, data):
    """A window whose gyro yaw rate is NaN is neither turning nor straight: it was left out
    of every figure without a word; now said (count, first windows), the figures those of
    the other windows alone."""
    rng = np.random.default_rng(seed)
    X = _features(_MEASURED, n)
    X["wz__mean"] = rng.choice([0.0, 0.02, 0.3, -0.4], size=n)
    gone = data.draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=n - 1, unique=True))
    X.loc[gone, "wz__mean"] = np.nan
    pred = np.column_stack([rng.uniform(0, 0.3, (n, 2)), rng.uniform(1, 3, n), np.zeros(n)])
    runs, terrains = np.array(["a", "b"] * (n // 2) + ["a"] * (n % 2)), np.array(["T"] * n)
    with pytest.warns(DataWarning, match=rf"{len(gone)} of {n} windows have no gyro yaw rate "
                      rf"\(wz__mean NaN\).*\(windows? {min(gone)}"):
        table = measured_checks(X, pred, runs, terrains, 0.5)
    keep = ~X["wz__mean"].isna().to_numpy()
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)     # no such window: nothing said
        alone = measured_checks(X[keep].reset_index(drop=True), pred[keep], runs[keep],
                                terrains[keep], 0.5)
    pd.testing.assert_frame_equal(table.drop(columns="n_runs"), alone.drop(columns="n_runs"))


def test_measured_checks_of_no_window_is_a_table_without_rows_with_its_columns():
    """No window (every one filtered out upstream) gave a frame without any column, where
    error_table and std_calibration_table keep theirs: a KeyError for whoever reads it."""
    table = measured_checks(_features(_MEASURED, 0), np.zeros((0, 4)), np.array([], str),
                            np.array([], str), 0.5)
    assert table.empty and list(table.columns) == [
        "terrain", "n_runs", "n_turning_windows", "yaw_rms_plain_rad_s",
        "yaw_rms_compensated_rad_s", "median_learned_minus_physics", "spearman_slip_current"]
    one = measured_checks(_features(_MEASURED, 1), np.ones((1, 4)), np.array(["r"]),
                          np.array(["T"]), 0.5)
    assert list(one.columns) == list(table.columns)


@FAST
@given(seed=st.integers(0, 9999), k=st.integers(2, 8), rho=st.one_of(
    st.none(), st.floats(-1, 1)), source=st.sampled_from(["physics", "learned", "fused"]))
def test_fused_pseudo_measurement_is_a_convex_mix_mirrored_and_scaled(seed, k, rho, source):
    """The fused slip lies between the physics and the learned slip, its std is at most the
    larger of theirs (the smaller with no correlation given); swapping the sides swaps
    the outputs; every slip, std and the floor scaled by 2^k scale slip and std by 2^k."""
    rng = np.random.default_rng(seed)
    m = 7
    t = np.arange(m) + 1.0
    sp, sl = rng.uniform(-0.3, 0.9, (2, m, 2))
    vp, cal = rng.uniform(1e-3, 0.2, (2, m, 2))
    cal[rng.random((m, 2)) < 0.3] = np.nan      # an uncalibrated window: the heuristic std
    settings_ = FusionSettings(min_std=1e-4, learned_std_floor=0.01, error_correlation=rho)
    outputs = {"physics": (t, sp, vp), "learned": (t, sl, cal)}
    _, slip, std = pseudo_measurement(outputs, source, settings_)
    if source == "fused":
        assert np.all(slip >= np.minimum(sp, sl) - 1e-12)
        assert np.all(slip <= np.maximum(sp, sl) + 1e-12)
        _, _, vl = pseudo_measurement(outputs, "learned", settings_)
        assert np.all(std <= np.maximum(vp, vl) * (1 + 1e-12))
        if rho is None:
            np.testing.assert_array_equal(std, np.minimum(vp, vl))
    swapped = {key: (tt, s[:, ::-1], v[:, ::-1]) for key, (tt, s, v) in outputs.items()}
    _, slip_s, std_s = pseudo_measurement(swapped, source, settings_)
    np.testing.assert_array_equal(slip_s, slip[:, ::-1])
    np.testing.assert_array_equal(std_s, std[:, ::-1])
    c = 2.0 ** k
    scaled = {key: (tt, c * s, c * v) for key, (tt, s, v) in outputs.items()}
    _, slip_c, std_c = pseudo_measurement(scaled, source, FusionSettings(
        min_std=c * 1e-4, learned_std_floor=c * 0.01, error_correlation=rho))
    np.testing.assert_allclose(slip_c, c * slip, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(std_c, c * std, rtol=1e-12)


@FAST
@given(seed=st.integers(0, 9999))
def test_fused_std_of_independent_and_of_fully_correlated_errors(seed):
    """Textbook cases of the inverse-variance mean: independent errors (rho 0) give
    1 / sqrt(1 / vp^2 + 1 / vl^2); fully correlated ones (rho 1) the weighted mean of the
    stds, ap vp + al vl."""
    rng = np.random.default_rng(seed)
    t = np.arange(5.0)
    sp, sl = rng.uniform(-0.3, 0.9, (2, 5, 2))
    vp, vl = rng.uniform(1e-3, 0.2, (2, 5, 2))
    outputs = {"physics": (t, sp, vp), "learned": (t, sl, vl)}
    _, _, std0 = pseudo_measurement(outputs, "fused", FusionSettings(min_std=1e-6,
                                                                     error_correlation=0.0))
    np.testing.assert_allclose(std0, (vp ** -2 + vl ** -2) ** -0.5, rtol=1e-12)
    _, _, std1 = pseudo_measurement(outputs, "fused", FusionSettings(min_std=1e-6,
                                                                     error_correlation=1.0))
    ap = vp ** -2 / (vp ** -2 + vl ** -2)
    np.testing.assert_allclose(std1, ap * vp + (1 - ap) * vl, rtol=1e-12)


@FAST
@given(seed=st.integers(0, 9999), r=st.lists(st.floats(-1, 1), min_size=2, max_size=2))
def test_fused_std_grows_with_the_assumed_error_correlation(seed, r):
    """The std of a weighted mean grows with the correlation of the errors averaged, on
    both sides of 0."""
    rng = np.random.default_rng(seed)
    t = np.arange(5.0)
    outputs = {"physics": (t, *rng.uniform(1e-3, 0.3, (2, 5, 2))),
               "learned": (t, *rng.uniform(1e-3, 0.3, (2, 5, 2)))}
    lo, hi = sorted(r)
    stds = [pseudo_measurement(outputs, "fused", FusionSettings(
        min_std=1e-9, error_correlation=rho))[2] for rho in (lo, hi)]
    assert np.all(stds[0] <= stds[1] * (1 + 1e-12) + 1e-15)


def test_fused_pseudo_measurement_keeps_the_learned_slip_where_the_physics_std_is_unknown():
    t = np.arange(2.0)
    outputs = {"physics": (t, np.full((2, 2), 0.1), np.array([[np.nan, 0.01], [0.01, 0.01]])),
               "learned": (t, np.full((2, 2), 0.12), np.full((2, 2), 0.02))}
    _, slip, std = pseudo_measurement(outputs, "fused", FusionSettings(min_std=1e-5))
    assert slip[0, 0] == 0.12 and std[0, 0] == 0.02


@pytest.mark.parametrize("rho", [None, 0.0, 0.5, -0.5])
def test_fused_takes_the_model_that_can_judge_a_window_side_alone(rho):
    """Learned unknown: the physics slip and std; physics unknown: the learned ones; both
    known: the weighted mean, as before; neither: NaN (the batch estimate skips it)."""
    t = np.arange(2.0)
    outputs = {"physics": (t, np.array([[0.1, 0.1], [np.nan, 0.1]]),
                           np.array([[0.01, 0.01], [0.01, np.nan]])),
               "learned": (t, np.array([[0.2, np.nan], [0.3, 0.3]]),
                           np.array([[0.01, 0.02], [np.nan, 0.04]]))}
    settings = FusionSettings(min_std=1e-5, error_correlation=rho)
    _, slip, std = pseudo_measurement(outputs, "fused", settings)
    assert slip[0, 0] == pytest.approx(0.15) and 0.0 < std[0, 0] <= 0.01   # both known
    assert slip[0, 1] == 0.1 and std[0, 1] == 0.01          # learned slip NaN: physics
    assert slip[1, 1] == 0.3 and std[1, 1] == 0.04          # physics std NaN: learned
    assert np.isnan(slip[1, 0]) or np.isnan(std[1, 0])      # physics slip and learned std NaN


@pytest.mark.parametrize("yaw", [np.zeros((6, 1)), np.zeros(5), np.zeros(7), 0.0])
def test_steady_straight_refuses_a_yaw_rate_not_one_per_window(yaw):
    """A yaw-rate column (n, 1) broadcast into an (n, n) mask without a word, another
    length was numpy's bare broadcast error."""
    meta = _meta(2, 3).assign(scenario="straight_accel", t_start_s=4.0)
    with pytest.raises(ShapeError, match=r"steady_straight: yaw_rate_rad_s must have shape "
                       r"\(6,\)"):
        steady_straight(meta, yaw)
    assert steady_straight(meta, np.zeros(6)).tolist() == [True] * 6


def test_a_zero_std_with_an_error_is_scored_uncovered_and_without_one_is_left_out():
    """std 0: an error > 0 is infinitely many stds off (scored, not covered); no error is
    0 / 0, no normalised error (counted out of n_scored)."""
    meta = _meta(1, 2)
    std = np.array([[0.0, 1.0], [0.0, 1.0]])
    pred = np.array([[0.5, 0.0], [0.0, 0.0]])
    table = std_calibration_table(pred, std, np.zeros((2, 2)), meta, np.ones(2, bool))
    row = table.iloc[0]
    assert row["n_scored"] == 3 and row["coverage_1std"] == 2 / 3


@FAST
@given(seed=st.integers(0, 9999), n_runs=st.integers(2, 7), n_folds=st.integers(2, 4))
def test_calibration_folds_are_grouped_and_blind_to_names_row_order_and_sides(
        seed, n_runs, n_folds):
    """Every window in one test fold, no run on both sides; renaming the runs (a random
    relabelling), shuffling the rows or swapping the sides deals the same windows together."""
    n_folds = min(n_folds, n_runs)
    rng = np.random.default_rng(seed)
    sizes = rng.integers(1, 5, n_runs)
    groups = np.repeat(np.arange(n_runs), sizes)
    n = len(groups)
    X = rng.normal(size=(n, 3))
    y = np.column_stack([rng.normal(size=(n, 2)), np.full(n, np.nan), rng.normal(size=n)])

    def partition(folds, rows=np.arange(n)):
        return sorted(sorted(rows[te].tolist()) for _, te in folds)

    folds = calibration_folds(X, y, groups, n_folds)
    test_of = np.concatenate([te for _, te in folds])
    assert sorted(test_of.tolist()) == list(range(n))
    for tr, te in folds:
        assert not set(groups[tr]) & set(groups[te])
        assert sorted(np.concatenate([tr, te]).tolist()) == list(range(n))
    base = partition(folds)
    names = np.array([f"run-{v}" for v in rng.permutation(1000)[:n_runs]])
    assert partition(calibration_folds(X, y, names[groups], n_folds)) == base
    order = rng.permutation(n)
    assert partition(calibration_folds(X[order], y[order], groups[order], n_folds),
                     order) == base
    assert partition(calibration_folds(X, y[:, [1, 0, 2, 3]], groups, n_folds)) == base


@pytest.mark.parametrize("Y", [np.zeros((6, 1)), np.zeros((5, 2)), np.zeros(6)])
def test_baseline_predictions_refuse_truth_not_both_sides_of_every_window(Y):
    """One truth column was taken for the slip of both sides in the eq. 22 fit, silently;
    another row count or a 1-D truth was a bare numpy IndexError."""
    with pytest.raises(ShapeError, match=r"baseline_predictions: Y must have shape \(6, >= 2\)"):
        baseline_predictions(_features(_BASELINE), Y, _meta(2, 3), np.ones(6, bool), [], 0.5)


def test_baseline_predictions_take_the_truth_as_a_nested_list():
    X, meta = _features(_BASELINE), _meta(1, 6)
    X["wz__mean"] = 0.0
    Y = np.random.default_rng(2).uniform(0, 0.2, (6, 4))
    runs, _, _ = _odometry_case(("sim/SNOW/turn/0",))
    meta = meta.assign(run_id=runs[0].run_id, terrain="SNOW")
    imu = pd.DataFrame({"t_s": runs[0].streams["wheels"]["t_s"], "wz": 0.0})
    run = Run(runs[0].run_id, "sim", "SNOW", {**runs[0].streams, "imu": imu})
    a = baseline_predictions(X, Y, meta, np.ones(6, bool), [run], 0.55)
    b = baseline_predictions(X, Y.tolist(), meta, np.ones(6, bool), [run], 0.55)
    np.testing.assert_array_equal(a["pitch-linear"], b["pitch-linear"])
