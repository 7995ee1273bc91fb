"""Review slp21: round trips and metamorphic relations of slip evaluation and the learned
slip model (grouping, hand-computed metrics, scale and permutation relations)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import MissingColumnError
from terrain.slip.evaluation import error_table, std_calibration_table

FAST = settings(max_examples=40, deadline=None)


def _meta(n_runs: int, per_run: int) -> pd.DataFrame:
    rid = np.repeat([f"r{i}" for i in range(n_runs)], per_run)
    return pd.DataFrame({"run_id": rid, "terrain": np.where(np.arange(len(rid)) % 2, "A", "B"),
                         "scenario": "s", "t_start_s": 0.0, "t_end_s": 2.0})


def test_error_table_groups_by_run():
    """Grouped by run (the unit of the splits), one row per run with its own median."""
    meta = _meta(3, 4)
    rng = np.random.default_rng(0)
    pred, truth = rng.normal(size=(12, 2)), np.zeros((12, 2))
    t = error_table(pred, truth, meta, np.ones(12, bool), by=("run_id",))
    assert list(t["run_id"]) == ["r0", "r1", "r2"]
    for i, rid in enumerate(t["run_id"]):
        e = np.abs(pred[4 * i:4 * i + 4]).ravel()
        assert t["median_abs_err"][i] == np.median(e)
    assert (t["n_runs"] == 1).all() and (t["n_windows"] == 4).all()


@pytest.mark.parametrize("table", [error_table, std_calibration_table])
def test_unknown_grouping_column_is_named(table):
    meta = _meta(2, 2)
    args = ((np.zeros((4, 2)), np.zeros((4, 2)), np.ones((4, 2)))
            if table is std_calibration_table else (np.zeros((4, 2)), np.zeros((4, 2))))
    with pytest.raises(MissingColumnError, match="surface"):
        table(*args, meta, np.ones(4, bool), by=("surface",))


@FAST
@given(st.integers(1, 4), st.integers(1, 5), st.floats(-50, 50).filter(lambda c: c != 0),
       st.integers(0, 2 ** 31 - 1))
def test_error_table_hand_computation_and_scale(n_runs, per_run, c, seed):
    """Median and p90 equal a hand computation over both sides; a perfect predictor scores
    0; scaling prediction and truth by c scales the errors by |c|."""
    meta = _meta(n_runs, per_run)
    n = len(meta)
    rng = np.random.default_rng(seed)
    pred, truth = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    mask = np.ones(n, bool)
    t = error_table(pred, truth, meta, mask, by=("scenario",))
    e = np.abs(pred - truth).ravel()
    assert t["median_abs_err"][0] == pytest.approx(np.median(e), abs=1e-12)
    assert t["p90_abs_err"][0] == pytest.approx(np.percentile(e, 90), abs=1e-12)
    assert t["n_scored"][0] == 2 * n and t["n_runs"][0] == n_runs
    assert error_table(truth, truth, meta, mask)["median_abs_err"].eq(0).all()
    s = error_table(c * pred, c * truth, meta, mask, by=("scenario",))
    assert s["median_abs_err"][0] == pytest.approx(abs(c) * t["median_abs_err"][0],
                                                   rel=1e-9, abs=1e-12)


class _Recorder:
    """Mean predictor that records the windows (index labels) it was fitted on."""

    seen: list = []

    def fit(self, X, Y):
        self.index = set(X.index)
        _Recorder.seen.append(self.index)
        self.mean = np.nanmean(Y, axis=0)
        return self

    def predict(self, X):
        return np.tile(self.mean, (len(X), 1))


@FAST
@given(st.lists(st.sampled_from("ABC"), min_size=4, max_size=30),
       st.integers(0, 2 ** 31 - 1))
def test_leave_one_out_never_sees_the_predicted_group(groups, seed):
    """Each test window's prediction is the mean of the train windows of other groups (a
    hand computation), from a model that saw none of its group's windows."""
    from terrain.slip.evaluation import leave_one_out

    groups = np.array(groups)
    n = len(groups)
    rng = np.random.default_rng(seed)
    test = rng.random(n) < 0.5
    test[0], test[-1] = True, False
    train = ~test
    X = pd.DataFrame({"f": rng.normal(size=n)})
    Y = rng.normal(size=(n, 2))
    _Recorder.seen = []
    out = leave_one_out(_Recorder, X, Y, groups, train, test)
    for i in range(n):
        other = train & (groups != groups[i])
        if test[i] and other.any():
            np.testing.assert_allclose(out[i], Y[other].mean(axis=0), rtol=1e-12)
        else:
            assert np.isnan(out[i]).all()
    for seen in _Recorder.seen:     # no model trained on a test window or on two sides
        assert not any(test[i] for i in seen)


@pytest.mark.parametrize("case", ["overlap", "empty_test", "empty_train"])
def test_leave_one_out_refuses_masks_as_documented(case):
    """Raises ConfigError "as fit_predict": overlapping or empty masks (an empty test mask
    returned all NaN, an overlapping pair was scored without a word)."""
    from terrain.errors import ConfigError
    from terrain.slip.evaluation import leave_one_out

    n = 6
    groups = np.array(list("AABBCC"))
    train = np.array([True, False] * 3)
    test = ~train
    if case == "overlap":
        test = test.copy()
        test[0] = True
    elif case == "empty_test":
        test = np.zeros(n, bool)
    else:
        train = np.zeros(n, bool)
    with pytest.raises(ConfigError, match="disjoint and non-empty"):
        leave_one_out(_Recorder, pd.DataFrame({"f": np.arange(float(n))}),
                      np.zeros((n, 2)), groups, train, test)


def _learned_data(n_runs: int = 6, per_run: int = 25, seed: int = 0):
    rng = np.random.default_rng(seed)
    n = n_runs * per_run
    X = pd.DataFrame(rng.normal(size=(n, 4)), columns=["a", "b", "c", "d"])
    noise = 0.02 * rng.normal(size=(n, 2))
    y = np.column_stack([0.1 * X.a + noise[:, 0], -0.1 * X.a + noise[:, 1],
                         np.where(X.d > 0, 2 + X.c, np.nan), 0.01 * X.b])
    return X, y, np.repeat(np.arange(n_runs), per_run)


def _fit(X, y, groups, **kw):
    import warnings

    from threadpoolctl import threadpool_limits

    from terrain.slip.learned import SlipRegressor

    with threadpool_limits(1, "openmp"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return SlipRegressor(max_iter=5, min_samples_leaf=5, calibration_folds=3,
                             **kw).fit(X, y, groups=groups)


@pytest.mark.slow
def test_learned_round_trips_bit_for_bit():
    """pickle and skops (the logged format) round trips, and a refit with the same seed,
    predict (compiled and reference path) and predict_std bit for bit."""
    import pickle

    import skops.io as sio

    X, y, groups = _learned_data()
    m = _fit(X, y, groups)
    p, s, v = m.predict(X), m.predict_std(X), m.predict_std(X, "variance")
    blob = sio.dumps(m)
    for other in (pickle.loads(pickle.dumps(m)),
                  sio.loads(blob, trusted=sio.get_untrusted_types(data=blob)),
                  _fit(X, y, groups)):
        assert np.array_equal(other.predict(X), p)
        assert np.array_equal(other.predict_reference(X), p)
        assert np.array_equal(other.predict_std(X), s)
        assert np.array_equal(other.predict_std(X, "variance"), v)
        assert other.calibration_ == m.calibration_


@pytest.mark.slow
def test_learned_metamorphic_rows_sides_columns():
    """Row order changes the fit at rounding level only; swapping the sides' targets swaps
    the predicted sides (the std is one per window: unchanged); a column permutation of the
    features with the same permutation at predict gives the same predictions."""
    X, y, groups = _learned_data()
    m = _fit(X, y, groups)
    p, s = m.predict(X), m.predict_std(X)
    perm = np.random.default_rng(1).permutation(len(X))
    r = _fit(X.iloc[perm], y[perm], groups[perm])
    np.testing.assert_allclose(r.predict(X), p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.predict_std(X), s, rtol=1e-9, atol=1e-15)
    w = _fit(X, y[:, [1, 0, 2, 3]], groups)
    np.testing.assert_allclose(w.predict(X)[:, [1, 0, 2, 3]], p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(w.predict_std(X), s, rtol=1e-9, atol=1e-15)
    cols = ["d", "b", "a", "c"]
    c = _fit(X[cols], y, groups)
    np.testing.assert_allclose(c.predict(X[cols]), p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.predict_std(X[cols]), s, rtol=1e-9, atol=1e-15)


@pytest.mark.slow
def test_learned_run_ids_change_no_prediction():
    """Run ids only group the calibration folds: any renaming leaves the predictions as
    they are, and a renaming that keeps their sorted order leaves the std too."""
    X, y, groups = _learned_data()
    m = _fit(X, y, groups)
    renamed = np.array(["z", "a", "m", "b", "y", "c"])[groups]
    assert np.array_equal(_fit(X, y, renamed).predict(X), m.predict(X))
    kept = np.array([f"sim/run/{g}" for g in groups])
    assert np.array_equal(_fit(X, y, kept).predict_std(X), m.predict_std(X))


def test_learned_std_independent_of_run_ids():
    """The calibration folds are dealt from the runs' data: GroupKFold dealt runs of equal
    window counts in the sorted order of their ids, so renaming runs moved the calibrated
    std (here by ~0.03 at a std ~0.05)."""
    X, y, groups = _learned_data()
    m = _fit(X, y, groups)
    renamed = np.array(["z", "a", "m", "b", "y", "c"])[groups]
    np.testing.assert_allclose(_fit(X, y, renamed).predict_std(X), m.predict_std(X),
                               rtol=1e-6)


@FAST
@given(st.integers(1, 4), st.integers(1, 6), st.floats(1e-3, 1e3),
       st.integers(0, 2 ** 31 - 1))
def test_std_calibration_hand_computation_and_scale(n_runs, per_run, c, seed):
    """Coverage, normalised squares, median std and error equal a hand computation over both
    sides; scaling prediction, truth and std by c > 0 changes only median_std and
    median_abs_err (by c); an exact std at every window covers all within 1 std."""
    meta = _meta(n_runs, per_run)
    n = len(meta)
    rng = np.random.default_rng(seed)
    pred, truth = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    std = rng.uniform(0.1, 2.0, size=(n, 2))
    mask = np.ones(n, bool)
    t = std_calibration_table(pred, std, truth, meta, mask).iloc[0]
    u = (np.abs(pred - truth) / std).ravel()
    assert t["n_scored"] == 2 * n and t["n_windows"] == n
    assert t["coverage_1std"] == pytest.approx(np.mean(u <= 1), abs=1e-12)
    assert t["coverage_2std"] == pytest.approx(np.mean(u <= 2), abs=1e-12)
    assert t["median_normalised_sq"] == pytest.approx(np.median(u ** 2), rel=1e-12)
    assert t["mean_normalised_sq"] == pytest.approx(np.mean(u ** 2), rel=1e-12)
    assert t["median_std"] == pytest.approx(np.median(std), rel=1e-12)
    s = std_calibration_table(c * pred, c * std, c * truth, meta, mask).iloc[0]
    for k in ("coverage_1std", "coverage_2std", "median_normalised_sq", "mean_normalised_sq"):
        assert s[k] == pytest.approx(t[k], rel=1e-9, abs=1e-9)
    for k in ("median_std", "median_abs_err"):
        assert s[k] == pytest.approx(c * t[k], rel=1e-9)
    exact = std_calibration_table(pred, np.abs(pred - truth) + 1e-12, truth, meta, mask)
    assert exact["coverage_1std"].eq(1.0).all()


@pytest.mark.parametrize("shape", [(4, 2), (3, 4), (4,)])
def test_odometry_errors_refuses_a_prediction_of_another_shape(shape):
    """pred is (n, 4) (slip_1, slip_2, chi, v_by per window of meta): a slip-only (n, 2)
    prediction was a bare IndexError inside the interpolation, another row count read
    other windows' predictions."""
    from terrain.errors import ShapeError
    from terrain.slip.evaluation import odometry_errors

    with pytest.raises(ShapeError, match="pred"):
        odometry_errors([], _meta(2, 2), np.zeros(shape), 0.5, [])


finite_slip = st.floats(-1.0, 1.0, allow_nan=False)
finite_std = st.floats(1e-4, 1.0, allow_nan=False)


@FAST
@given(st.lists(st.tuples(finite_slip, finite_slip, finite_std, finite_std),
                min_size=1, max_size=8),
       st.one_of(st.none(), st.floats(-1.0, 1.0)))
def test_fused_pseudo_measurement_is_a_convex_combination(rows, rho):
    """The fused slip lies between the physics and learned slips; its std is at most the
    larger of the two (at most the smaller for uncorrelated errors, and the smaller when
    the correlation is None); equal inputs fuse to themselves; swapping the sides swaps the
    outputs."""
    from terrain.slip.estimate import FusionSettings, pseudo_measurement

    a = np.array(rows)
    t = np.arange(len(a), dtype=float)
    sp, sl = np.repeat(a[:, :1], 2, axis=1), np.repeat(a[:, 1:2], 2, axis=1)
    sp[:, 1] *= -0.5
    vp, vl = np.repeat(a[:, 2:3], 2, axis=1), np.repeat(a[:, 3:4], 2, axis=1)
    settings = FusionSettings(min_std=1e-6, error_correlation=rho)
    out = {"physics": (t, sp, vp), "learned": (t, sl, vl)}
    _, mean, std = pseudo_measurement(out, "fused", settings)
    lo, hi = np.minimum(sp, sl), np.maximum(sp, sl)
    assert np.all(mean >= lo - 1e-12) and np.all(mean <= hi + 1e-12)
    assert np.all(std <= np.maximum(vp, vl) * (1 + 1e-9))
    if rho is None or rho == 0:
        assert np.all(std <= np.minimum(vp, vl) * (1 + 1e-9))
    _, same, same_std = pseudo_measurement({"physics": (t, sp, vp), "learned": (t, sp, vp)},
                                           "fused", FusionSettings(min_std=1e-6,
                                                                   error_correlation=None))
    np.testing.assert_allclose(same, sp, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(same_std, vp, rtol=1e-12)
    sw = {k: (t, s[:, ::-1], v[:, ::-1]) for k, (_, s, v) in out.items()}
    _, m2, s2 = pseudo_measurement(sw, "fused", settings)
    np.testing.assert_array_equal(m2, mean[:, ::-1])
    np.testing.assert_array_equal(s2, std[:, ::-1])


def test_learned_score_by_hand_and_refuses_other_targets():
    """score is minus the median absolute slip error over both sides (0 for a perfect
    target); y of another shape is a ShapeError (a 1-D y was a bare IndexError, another row
    count a broadcasting ValueError)."""
    from terrain.errors import ShapeError

    X, y, groups = _learned_data()
    m = _fit(X, y, groups)
    p = m.predict(X)
    assert m.score(X, p) == 0.0
    assert m.score(X, y) == -np.median(np.abs(p[:, :2] - y[:, :2]).ravel())
    for bad in (y[:, 0], y[:-1], y[:, :1]):
        with pytest.raises(ShapeError, match="y"):
            m.score(X, bad)


@pytest.mark.parametrize("missing", [np.nan, None])
def test_leave_one_out_refuses_a_window_without_group(missing):
    """A window whose group is NaN or None cannot be left out with its group: NaN was
    'train and test windows must be disjoint and non-empty' (masks that were fine), None a
    bare TypeError from sorting; now NonFiniteInputError naming groups."""
    from terrain.errors import NonFiniteInputError
    from terrain.slip.evaluation import leave_one_out

    groups = np.array(["a", "a", missing, missing, "b", "b"], dtype=object)
    train = np.array([True, False] * 3)
    with pytest.raises(NonFiniteInputError, match="groups"):
        leave_one_out(_Recorder, pd.DataFrame({"f": np.arange(6.0)}), np.zeros((6, 2)),
                      groups, train, ~train)


@pytest.mark.parametrize("missing", [np.nan, None])
def test_learned_fit_refuses_a_window_without_run(missing):
    """A missing run id in groups (the calibration folds) was a bare TypeError (None) or
    scikit-learn's 'Input groups contains NaN', after the four fits; now
    NonFiniteInputError naming groups, before any fit."""
    from terrain.errors import NonFiniteInputError

    X, y, groups = _learned_data()
    groups = groups.astype(object)
    groups[3] = missing
    with pytest.raises(NonFiniteInputError, match="groups"):
        _fit(X, y, groups)


def test_learned_constant_chi_is_the_median_of_the_turning_targets():
    """Fewer than 2 min_samples_leaf turning windows: chi is the median of their targets on
    every window (1 without any), in predict and predict_reference alike."""
    X, y, groups = _learned_data()
    y = y.copy()
    y[:, 2] = np.nan
    y[:7, 2] = [1.5, 2.0, 2.5, 3.0, 1.0, 4.0, 2.2]
    m = _fit(X, y, groups)
    assert m.chi_model_ is None
    assert np.all(m.predict(X)[:, 2] == np.median(y[:7, 2]))
    assert np.array_equal(m.predict(X), m.predict_reference(X))
    y[:, 2] = np.nan
    assert np.all(_fit(X, y, groups).predict(X)[:, 2] == 1.0)


def test_fit_predict_and_leave_one_out_take_targets_as_a_nested_list():
    """Y given as a list of (left, right) pairs was a bare AttributeError (Y.shape) or
    TypeError (Y[mask]) in fit_predict and leave_one_out (slp21's left-alone); it is read as
    the array it holds, with the same predictions."""
    from terrain.slip.evaluation import fit_predict, leave_one_out

    rng = np.random.default_rng(3)
    n = 12
    X = pd.DataFrame({"f": rng.normal(size=n)})
    Y = rng.normal(size=(n, 2))
    groups = np.array(list("AABBCC") * 2)
    test = np.arange(n) % 2 == 0
    for call in (lambda y: fit_predict(_Recorder, X, y, ~test, test),
                 lambda y: leave_one_out(_Recorder, X, y, groups, ~test, test)):
        np.testing.assert_array_equal(call(Y.tolist()), call(Y))


def test_calibration_folds_put_the_seeds_of_one_trajectory_apart_whatever_their_names():
    """Runs with identical targets (one scripted trajectory under other sensor noise) go to
    different calibration folds, as GroupKFold put them only because their ids sorted next
    to each other; the folds are the same sets of windows under any renaming or row
    order."""
    from terrain.slip.learned import calibration_folds

    rng = np.random.default_rng(4)
    n_traj, per_run = 6, 10
    truth = [np.column_stack([rng.normal(0.05 * k, 0.01, per_run),
                              rng.normal(0.05 * k, 0.01, per_run),
                              np.full(per_run, np.nan), rng.normal(size=per_run)])
             for k in range(n_traj)]
    # two seeds each, after two longer runs that leave the folds unequal (30, 25, 0 windows)
    y = np.vstack([truth[k] for k in range(n_traj) for _ in range(2)]
                  + [rng.normal(size=(30, 4)), rng.normal(size=(25, 4))])
    X = rng.normal(size=(len(y), 3))
    run = np.concatenate([np.repeat(np.arange(2 * n_traj), per_run),
                          np.full(30, 2 * n_traj), np.full(25, 2 * n_traj + 1)])
    names = np.array([f"{'ab'[s]}{k}" for k in range(n_traj) for s in range(2)]
                     + ["long", "longer"])[run]

    def as_sets(folds, rows):
        return sorted(tuple(sorted(rows[te])) for _, te in folds)

    folds = calibration_folds(X, y, names, 3)
    fold_of = {}
    for f, (_, te) in enumerate(folds):
        for r in np.unique(run[te]):
            fold_of[r] = f
    assert all(fold_of[2 * k] != fold_of[2 * k + 1] for k in range(n_traj))
    rows = np.arange(len(y))
    perm = rng.permutation(len(y))
    renamed = np.array([f"z{rng.integers(1000)}_{i}" for i in range(2 * n_traj + 2)])[run]
    assert as_sets(calibration_folds(X[perm], y[perm], renamed[perm], 3), rows[perm]) == \
        as_sets(folds, rows)
