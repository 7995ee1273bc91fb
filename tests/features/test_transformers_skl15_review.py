"""The window feature transformers as scikit-learn transformers: fitted attributes and
row-wise properties (a window's features depend on that window alone)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import clone
from sklearn.pipeline import FeatureUnion, Pipeline
from sklearn.preprocessing import StandardScaler

from features.transformers import SerialFeatureUnion, WindowFeatures
from features.wheel_physics import WheelPhysicsFeatures
from terrain.run import WHEEL_CHANNELS

RATE_HZ = 20.0
CHANNELS = ("ax", "wz", "vel_l", "vel_r", "cur_l", "cur_r")


def _windows(n: int = 5, n_samples: int = 40, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = rng.normal(0.0, 1.0, (n, len(CHANNELS), n_samples))
    X[:, 2:4] += 0.6        # driving forward
    X[:, 4:] += 5.0         # motor currents
    return X


@pytest.mark.parametrize("make", [lambda: WindowFeatures(CHANNELS, RATE_HZ),
                                  lambda: WheelPhysicsFeatures(CHANNELS, RATE_HZ)])
def test_fit_records_the_channels_as_n_features_in(make):
    # scikit-learn's Pipeline and FeatureUnion read n_features_in_ from their first step:
    # without it a fitted window SVM had none ("'WindowFeatures' object has no attribute
    # 'n_features_in_'"), while the CNNs, the ensemble and the wrappers record the channels
    X = _windows()
    assert make().fit(X).n_features_in_ == len(CHANNELS)
    pipe = Pipeline([("features", make()), ("scale", StandardScaler())]).fit(X)
    assert pipe.n_features_in_ == len(CHANNELS)
    union = SerialFeatureUnion([("a", make())]).fit(X)
    assert union.n_features_in_ == len(CHANNELS)


def test_a_refit_on_other_channels_records_their_number():
    X = _windows()
    fx = WindowFeatures(CHANNELS, RATE_HZ).fit(X)
    fx.set_params(channels=CHANNELS[:2]).fit(X[:, :2])
    assert fx.n_features_in_ == 2
    assert clone(fx).get_params()["channels"] == CHANNELS[:2]


def _both(X: np.ndarray) -> np.ndarray:
    union = FeatureUnion([("stats", WindowFeatures(CHANNELS, RATE_HZ)),
                          ("physics", WheelPhysicsFeatures(CHANNELS, RATE_HZ, short_s=1.0))])
    return union.fit(X).transform(X)


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 7), st.integers(0, 2 ** 32 - 1), st.data())
def test_features_of_a_window_do_not_depend_on_the_others(n, seed, draw):
    # scikit-learn's subset and sample-order invariance, on windows: a batch, its shuffled
    # rows and each window alone give the same rows (as fast paths may batch differently)
    X = _windows(n=n, seed=seed)
    order = np.asarray(draw.draw(st.permutations(range(n))))
    F = _both(X)
    np.testing.assert_allclose(_both(X[order]), F[order], rtol=1e-12, atol=1e-12)
    i = draw.draw(st.integers(0, n - 1))
    np.testing.assert_allclose(_both(X[i:i + 1])[0], F[i], rtol=1e-12, atol=1e-12)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2 ** 32 - 1))
def test_fit_is_stateless_in_the_window_values(seed):
    # fit fixes names and FFT helpers from the settings and the window length only, so
    # features computed before cross-validation leak nothing between folds
    X, other = _windows(seed=seed), _windows(n=3, seed=seed + 1)
    for make in (lambda: WindowFeatures(CHANNELS, RATE_HZ),
                 lambda: WheelPhysicsFeatures(CHANNELS, RATE_HZ)):
        np.testing.assert_array_equal(make().fit(X).transform(X),
                                      make().fit(other).transform(X))


def test_wheel_channels_are_in_the_test_layout():
    assert set(WHEEL_CHANNELS) <= set(CHANNELS)
