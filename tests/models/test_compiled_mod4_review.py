"""Review tests (mod4) of the compiled fast path (when it must give way to scikit-learn's) and
of the MiniRocket windows."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.preprocessing import StandardScaler

from terrain.models.compiled import CompiledPipeline, scale_unchecked


class _Final(ClassifierMixin, BaseEstimator):
    """A final step whose predict_proba takes a routed parameter."""

    def fit(self, X, y):
        self.classes_ = np.unique(y)
        return self

    def predict_proba(self, X, shift=0.0):
        return np.full((len(X), 2), 0.5) + shift * np.array([1.0, -1.0])

    def predict(self, X, shift=0.0):
        return self.classes_[self.predict_proba(X, shift).argmax(axis=1)]


class _Toy(CompiledPipeline):
    def _compiled(self):
        return self.steps[-1][1]

    def _compiled_proba(self, compiled, Xt):
        return np.tile([0.9, 0.1], (len(Xt), 1))


def test_a_scaler_fitted_on_another_width_is_left_to_scikit_learn():
    """A one-column input broadcast against a 3-feature scaler into a (n, 3) result."""
    F = np.random.default_rng(0).normal(size=(20, 3))
    scaler = StandardScaler().fit(F)
    assert scale_unchecked(scaler, F[:, :1]) is None
    assert scale_unchecked(scaler, F[:, :2].astype(np.float32)) is None
    assert scale_unchecked(scaler, F).shape == (20, 3)


def test_routed_parameters_take_scikit_learns_path():
    X = np.random.default_rng(0).normal(size=(6, 3))
    y = np.array([0, 1] * 3)
    model = _Toy([("scale", StandardScaler()), ("final", _Final())]).fit(X, y)
    np.testing.assert_array_equal(model.predict_proba(X[:2]), [[0.9, 0.1]] * 2)
    np.testing.assert_allclose(model.predict_proba(X[:2], shift=0.25), [[0.75, 0.25]] * 2)
    assert model.predict(X[:2]).tolist() == [0, 0]
    assert model.predict(X[:2], shift=-0.25).tolist() == [1, 1]


def test_passthrough_steps_are_skipped_on_the_fast_path():
    X = np.random.default_rng(0).normal(size=(6, 3))
    y = np.array([0, 1] * 3)
    model = _Toy([("scale", StandardScaler()), ("skip", "passthrough"), ("none", None),
                  ("final", _Final())]).fit(X, y)
    np.testing.assert_array_equal(model.predict_proba(X[:2]), [[0.9, 0.1]] * 2)


@pytest.mark.slow
def test_minirocket_refuses_boolean_windows():
    """aeon read a mask handed over for the signals (X > 0) as 0/1 windows, silently."""
    pytest.importorskip("aeon")
    from terrain.models.minirocket import make_minirocket

    rng = np.random.default_rng(0)
    X = rng.normal(size=(12, 2, 40)).astype(np.float32)
    y = np.array(["A", "B", "C"] * 4)
    with pytest.raises(ValueError, match="windows hold booleans"):
        make_minirocket(0, n_kernels=84, max_dilations_per_kernel=2).fit(X > 0, y)
    model = make_minirocket(0, n_kernels=84, max_dilations_per_kernel=2).fit(X, y)
    with pytest.raises(ValueError, match="windows hold booleans"):
        model.predict_proba(X[:1] > 0)
    with pytest.raises(ValueError, match="windows hold booleans"):
        model.named_steps["minirocket"].transform((X[:1] > 0).tolist())


@pytest.mark.parametrize("bad", [np.inf, -np.inf, np.nan, 1e40])
def test_minirocket_refuses_windows_that_are_not_finite_in_float32(bad):
    """aeon refuses NaN but transformed inf (and 1e40, inf once cast to float32) into finite
    features: fit and predict_proba gave probabilities without a word."""
    pytest.importorskip("aeon")
    from terrain.models.minirocket import make_minirocket

    rng = np.random.default_rng(0)
    X = rng.normal(size=(12, 2, 40))
    y = np.array(["A", "B", "C"] * 4)
    spoiled = X.copy()
    spoiled[1, 0, 3] = bad
    with pytest.raises(ValueError, match=r"not finite .*window 1, channel 0, sample 3"):
        make_minirocket(0, n_kernels=84, max_dilations_per_kernel=2).fit(spoiled, y)
    model = make_minirocket(0, n_kernels=84, max_dilations_per_kernel=2).fit(X, y)
    with pytest.raises(ValueError, match=r"not finite .*window 1, channel 0, sample 3"):
        model.predict_proba(spoiled[:2])
    with pytest.raises(ValueError, match=r"not finite .*window 1, sample 3"):
        make_minirocket(0, n_kernels=84, max_dilations_per_kernel=2).fit(spoiled[:, 0], y)
