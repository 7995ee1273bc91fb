"""State and reuse of the learned slip model (review est23)."""

from __future__ import annotations

import copy
import pickle
import warnings

import numpy as np
import pytest

from terrain.slip.learned import SlipRegressor


def _data(n: int, d: int, seed: int):
    r = np.random.default_rng(seed)
    X = r.normal(size=(n, d))
    y = np.column_stack([0.1 * X[:, 0], 0.1 * X[:, 1], 1.0 + 0.1 * X[:, 0], 0.01 * X[:, 2]])
    return X, y, np.repeat(np.arange(n // 40), 40)[:n]


def _model() -> SlipRegressor:
    return SlipRegressor(max_iter=15, min_samples_leaf=5)


@pytest.mark.filterwarnings("ignore")
def test_a_failed_refit_leaves_the_fitted_model_as_it_was():
    """A fit that raises (here scikit-learn's refusal of an empty table) must not leave the
    model half refitted: it said n_features_in_ = 3 while its trees read 5 columns, and
    refused both."""
    X, y, g = _data(400, 5, 1)
    m = _model().fit(X, y, g)
    before = (m.predict(X[:20]), m.predict_std(X[:20]), m.n_features_in_, sorted(vars(m)))
    with pytest.raises(Exception):
        m.fit(np.zeros((0, 3)), np.zeros((0, 4)))
    np.testing.assert_array_equal(m.predict(X[:20]), before[0])
    np.testing.assert_array_equal(m.predict_std(X[:20]), before[1])
    assert m.n_features_in_ == before[2]
    assert sorted(vars(m)) == before[3]


@pytest.mark.slow
def test_refit_forgets_the_first_fit_and_copies_are_independent():
    XA, yA, gA = _data(400, 5, 1)
    XB, yB, gB = _data(400, 3, 2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fresh = _model().fit(XB, yB)
        refit = _model().fit(XA, yA, gA).fit(XB, yB)
    assert sorted(vars(refit)) == sorted(vars(fresh))
    np.testing.assert_array_equal(refit.predict(XB), fresh.predict(XB))
    np.testing.assert_array_equal(refit.predict_std(XB), fresh.predict_std(XB))
    fitted = _model().fit(XA, yA, gA)
    ref = (fitted.predict(XA), fitted.predict_std(XA))
    for c in (pickle.loads(pickle.dumps(fitted)), copy.deepcopy(fitted)):
        np.testing.assert_array_equal(c.predict(XA), ref[0])
        np.testing.assert_array_equal(c.predict_std(XA), ref[1])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            c.fit(XB, yB)
        np.testing.assert_array_equal(fitted.predict(XA), ref[0])


def test_fit_leaves_its_inputs_and_numpys_global_generator_alone():
    X, y, g = _data(400, 5, 3)
    y[::7, 2] = np.nan
    keep = copy.deepcopy((X, y, g))
    state = np.random.get_state()
    _model().fit(X, y, g)
    after = np.random.get_state()
    np.testing.assert_array_equal(state[1], after[1])
    assert state[2] == after[2]
    for a, b in zip((X, y, g), keep):
        np.testing.assert_array_equal(a, b)
