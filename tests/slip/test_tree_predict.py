"""Compiled tree adaptor (terrain.tree_predict) and the single-window feature path: both
must reproduce the reference paths exactly (issue 10, single-window inference)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.ensemble import HistGradientBoostingRegressor

from features.slip_features import (SLIP_WINDOW, one_hot_probabilities, slip_features,
                                    slip_windows, window_feature_vector)
from terrain.errors import ConfigError, MissingColumnError, ShapeError
from terrain.slip.dataset import SlipDataSpec, simulated_runs
from terrain.slip.learned import SlipRegressor
from terrain.tree_predict import pack_trees, predict_packed
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.vehicles import HUSKY


def _data(n=600, f=7, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, f))
    y = np.sin(2 * X[:, 0]) + X[:, 1] * X[:, 2] + 0.1 * rng.normal(size=n)
    X[rng.random(X.shape) < 0.05] = np.nan          # missing values take the learned side
    return X, y


def test_packed_trees_bit_identical_to_sklearn_with_missing_values():
    X, y = _data()
    models = [HistGradientBoostingRegressor(max_iter=40, early_stopping=False,
                                            random_state=0).fit(X, y + k) for k in range(3)]
    packed = pack_trees(models, X.shape[1])
    Xt, _ = _data(n=300, seed=1)
    Xt[0, :] = np.nan
    Xt[1, 0] = np.inf
    out = predict_packed(packed, Xt)
    ref = np.column_stack([m.predict(Xt) for m in models])
    assert np.array_equal(out, ref)                  # same sums in the same order, not approx
    assert np.array_equal(predict_packed(packed, Xt[5:6]), ref[5:6])   # a single row
    assert np.ptp(out[:, 0]) > 1.0                  # the trees actually split
    with pytest.raises(ShapeError):
        predict_packed(packed, Xt[:, :3])


def test_inputs_on_a_split_threshold_go_left_as_in_sklearn():
    # integer features: the bins split half-way (x <= 1.5 goes left); inputs on the
    # thresholds themselves must take scikit-learn's side
    rng = np.random.default_rng(0)
    X = rng.integers(0, 5, (400, 2)).astype(float)
    y = X[:, 0] * X[:, 1] + 0.1 * rng.normal(size=400)
    model = HistGradientBoostingRegressor(max_iter=20, early_stopping=False,
                                          random_state=0).fit(X, y)
    grid = np.stack(np.meshgrid(np.arange(-0.5, 5.0, 0.5), np.arange(-0.5, 5.0, 0.5)),
                    axis=-1).reshape(-1, 2)
    out = predict_packed(pack_trees([model], 2), grid)[:, 0]
    assert np.array_equal(out, model.predict(grid))


def test_pack_rejects_what_it_cannot_reproduce():
    X, y = _data()
    with pytest.raises(ConfigError):
        pack_trees([HistGradientBoostingRegressor()], X.shape[1])      # not fitted
    with pytest.raises(ConfigError):
        pack_trees([HistGradientBoostingRegressor(loss="poisson", max_iter=5).fit(
            X, np.abs(y))], X.shape[1])                               # log link
    Xc = np.column_stack([X[:, :2], np.arange(len(X)) % 3])
    cat = HistGradientBoostingRegressor(max_iter=5, categorical_features=[2]).fit(
        np.nan_to_num(Xc), y + 3 * (Xc[:, 2] == 1))
    with pytest.raises(ConfigError):
        pack_trees([cat], 3)
    with pytest.raises(ConfigError):
        pack_trees([], 3)


def test_pack_refuses_a_feature_count_other_than_the_estimators():
    # pack_trees([m], 1) for a model fitted on 7 features walked X's row past its end
    # (no bounds check in the compiled loop): other rows' values, silently; with 9, X's
    # extra columns were taken where scikit-learn refuses the table
    X, y = _data()
    model = HistGradientBoostingRegressor(max_iter=5, random_state=0).fit(X, y)
    for n_features in (1, X.shape[1] + 2):
        with pytest.raises(ConfigError, match=f"fitted on {X.shape[1]} features"):
            pack_trees([model], n_features)


@pytest.fixture(scope="module")
def one_run(tmp_path_factory):
    spec = SlipDataSpec(terrains=("SNOW",), scenarios=("random",), seeds=(0,), duration_s=12.0)
    return simulated_runs(spec, tmp_path_factory.mktemp("slipcache"))


def test_single_window_features_equal_the_table_row(one_run):
    ws = slip_windows(one_run, SLIP_WINDOW)
    probs = one_hot_probabilities(["SNOW"] * len(ws), TERRAIN_NAMES)
    table = slip_features(ws, HUSKY, probs)
    p = {t: float(t == "SNOW") for t in TERRAIN_NAMES}
    for i in (0, len(ws) // 2, len(ws) - 1):
        vec = window_feature_vector(ws.X[i], ws.channels, ws.rate_hz, HUSKY, p)
        assert np.array_equal(vec, table.iloc[i].to_numpy())
    no_terrain = slip_features(ws, HUSKY)
    vec = window_feature_vector(ws.X[0], ws.channels, ws.rate_hz, HUSKY)
    assert np.array_equal(vec, no_terrain.iloc[0].to_numpy())
    assert table["phys_slip_l"].abs().max() > 0.01     # snow slips: the physics path ran
    with pytest.raises(ConfigError):
        window_feature_vector(ws.X[0][:3], ws.channels, ws.rate_hz, HUSKY)


def test_slip_regressor_compiled_predict_equals_reference(one_run):
    ws = slip_windows(one_run, SLIP_WINDOW)
    X = slip_features(ws, HUSKY, one_hot_probabilities(["SNOW"] * len(ws), TERRAIN_NAMES))
    rng = np.random.default_rng(0)
    chi = np.where(rng.random(len(X)) < 0.5, np.nan, 1.0 + rng.random(len(X)))
    y = np.column_stack([rng.random(len(X)), rng.random(len(X)), chi, rng.normal(size=len(X))])
    model = SlipRegressor(max_iter=20, min_samples_leaf=2).fit(X, y)
    assert model.chi_model_ is not None
    assert np.array_equal(model.predict(X), model.predict_reference(X))
    assert np.array_equal(model.predict(X.iloc[[3]]), model.predict_reference(X.iloc[[3]]))
    del model.packed_trees_                           # a model pickled before the adaptor
    assert np.array_equal(model.predict(X), model.predict_reference(X))
    with pytest.raises(MissingColumnError):         # a named table: the columns named
        model.predict(X.iloc[:, :5])
    with pytest.raises(ShapeError):                 # a bare array: its width
        model.predict(X.to_numpy()[:, :5])
    y[3:, 2] = np.nan                                 # too few turning windows: chi default
    model = SlipRegressor(max_iter=20, min_samples_leaf=2).fit(X, y)
    assert model.chi_model_ is None
    assert np.array_equal(model.predict(X), model.predict_reference(X))
    assert np.all(model.predict(X)[:, 2] == model.chi_default_)


@pytest.mark.slow
def test_calibrated_std_recovers_planted_heteroscedastic_noise():
    """Slip noise planted 0.004 where feature 0 < 0 and 0.02 where > 0: the std calibrated on
    grouped out-of-fold residuals follows it (and is NaN without groups)."""
    rng = np.random.default_rng(3)
    n = 4000
    X = rng.normal(size=(n, 5))
    sigma = np.where(X[:, 0] > 0, 0.02, 0.004)
    base = 0.1 + 0.05 * np.tanh(X[:, 1])
    y = np.column_stack([base + sigma * rng.normal(size=n), base + sigma * rng.normal(size=n),
                         np.full(n, np.nan), np.zeros(n)])
    groups = np.arange(n) // 40                      # 100 "runs" of 40 windows
    model = SlipRegressor(max_iter=60, learning_rate=0.1, max_leaf_nodes=7,
                          min_samples_leaf=40).fit(X, y, groups=groups)
    Xt = rng.normal(size=(2000, 5))
    sd = model.predict_std(Xt)
    assert sd.shape == (2000, 2) and np.all(sd >= model.std_floor)
    hi, lo = np.median(sd[Xt[:, 0] > 0.3, 0]), np.median(sd[Xt[:, 0] < -0.3, 0])
    assert 0.6 * 0.02 < hi < 1.5 * 0.02, hi            # the planted levels, within the
    assert 0.6 * 0.004 < lo < 1.7 * 0.004, lo          # fold models' own estimation error
    cal = model.calibration_
    assert 0.55 < cal["coverage_1std"] < 0.8 and 0.88 < cal["coverage_2std"] < 0.99
    # held-out planted data: about 68 % within 1 std
    yt = 0.1 + 0.05 * np.tanh(Xt[:, 1]) + np.where(Xt[:, 0] > 0, 0.02, 0.004) * rng.normal(
        size=2000)
    cover = np.mean(np.abs(model.predict(Xt)[:, 0] - yt) <= sd[:, 0])
    assert 0.55 < cover < 0.8, cover
    plain = SlipRegressor(max_iter=20).fit(X, y)
    assert np.isnan(plain.predict_std(Xt)).all()
    with pytest.raises(ShapeError):
        SlipRegressor(max_iter=5).fit(X, y, groups=groups[:10])
