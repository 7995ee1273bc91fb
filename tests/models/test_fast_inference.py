"""Single-window fast paths (issue 13) give the outputs of the library paths they replace.

CNNs: the direct ``inference_mode`` forward equals skorch's ``predict_proba`` on the same
standardised input; the NumPy input check accepts what ``check_array`` accepts, unchanged.
Ensemble: the precomputed class columns give the sum of :func:`aligned_proba` exactly.
MiniRocket: the NumPy scaler and logistic regression equal scikit-learn's, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_array

from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
from terrain.models.compiled import scale_unchecked
from terrain.models.ensemble import SoftVotingEnsemble, aligned_proba

#: tiny, fast networks (the library defaults are the measured ones)
FAST = dict(max_epochs=3, width=4, batch_size=16, n_threads=1, device="cpu")


def _windows(n_per_class: int = 12, n_classes: int = 3, n_channels: int = 3,
             n_samples: int = 100, seed: int = 0):
    """Classes differ by a tone of ``5 (k + 1)`` Hz on channel 0 (100 Hz clock)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_samples) / 100.0
    X, y = [], []
    for k in range(n_classes):
        for _ in range(n_per_class):
            w = rng.normal(0.0, 1.0, (n_channels, n_samples))
            w[0] += 2.0 * np.sin(2 * np.pi * 5.0 * (k + 1) * t + rng.uniform(0, 6.3))
            X.append(w)
            y.append(f"T{k}")
    return np.asarray(X), np.asarray(y)


@pytest.fixture(scope="module")
def cnns():
    X, y = _windows()
    return X, y, [RawCNNClassifier(**FAST).fit(X, y),
                  SpectrogramCNNClassifier(segment_s=0.2, hop_s=0.1, **FAST).fit(X, y)]


def test_direct_forward_equals_skorch_predict_proba(cnns):
    X, _, models = cnns
    for model in models:
        Z = model._standardise(model._inputs(X.astype(np.float32)))
        skorch = model.net_.predict_proba(Z)              # DataLoader path of skorch
        np.testing.assert_allclose(model.predict_proba(X), skorch, rtol=0, atol=1e-6)
        single = np.concatenate([model.predict_proba(X[i:i + 1]) for i in range(5)])
        np.testing.assert_allclose(single, skorch[:5], rtol=0, atol=1e-6)


@pytest.mark.filterwarnings("ignore:overflow encountered in cast:RuntimeWarning")
def test_input_check_shortcut_accepts_what_check_array_accepts():
    X, _ = _windows(n_per_class=2)
    for arr in (X, X.astype(np.float32), X[:, 0, :], np.asfortranarray(X)):
        fast = RawCNNClassifier._check_windows(arr)
        reference = check_array(arr, ensure_2d=True, allow_nd=True, dtype=np.float32)
        assert fast.dtype == np.float32
        np.testing.assert_array_equal(fast, reference)
    bad = X.copy()
    bad[0, 1, 2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        RawCNNClassifier._check_windows(bad)
    with pytest.raises(ValueError, match="infinity|too large"):
        RawCNNClassifier._check_windows(np.full((2, 3, 4), 1e39))   # inf in float32
    with pytest.raises(ValueError):
        RawCNNClassifier._check_windows(np.zeros((0, 3, 4)))


def test_ensemble_columns_give_the_aligned_sum(cnns):
    X, y, models = cnns
    ens = SoftVotingEnsemble([("raw", RawCNNClassifier(**FAST)),
                              ("spec", SpectrogramCNNClassifier(segment_s=0.2, hop_s=0.1,
                                                                **FAST))],
                             weights=(1.0, 3.0)).fit(X, y)
    expected = sum(w * aligned_proba(est, X, ens.classes_)
                   for w, est in zip(ens.weights_, ens.estimators_))
    np.testing.assert_array_equal(ens.predict_proba(X), expected)
    del ens.columns_                                      # an ensemble pickled before them
    np.testing.assert_array_equal(ens.predict_proba(X), expected)
    assert clone(ens).get_params()["weights"] == (1.0, 3.0)


def test_ensemble_member_missing_a_class_gets_zero_in_its_column():
    X, y = _windows(n_per_class=6)

    class MeanLogReg(LogisticRegression):
        def fit(self, X, y):
            return super().fit(X.mean(axis=2), y)

        def predict_proba(self, X):
            return super().predict_proba(X.mean(axis=2))

    ens = SoftVotingEnsemble([("a", MeanLogReg()), ("b", MeanLogReg())]).fit(X, y)
    partial = MeanLogReg().fit(X[y != "T1"], y[y != "T1"])  # never saw T1
    ens.estimators_[1] = partial
    del ens.columns_
    p = ens.predict_proba(X)
    np.testing.assert_array_equal(
        p, 0.5 * aligned_proba(ens.estimators_[0], X, ens.classes_)
        + 0.5 * aligned_proba(partial, X, ens.classes_))
    np.testing.assert_allclose(p[:, 1], 0.5 * ens.estimators_[0].predict_proba(X)[:, 1])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_unchecked_scaler_equals_standard_scaler(dtype):
    rng = np.random.default_rng(0)
    F = (rng.normal(3.0, 2.0, (40, 7))).astype(dtype)
    scaler = StandardScaler().fit(F[:30])
    out = scale_unchecked(scaler, F[30:])
    assert out.dtype == dtype
    np.testing.assert_array_equal(out, scaler.transform(F[30:]))
    nan = F[30:].copy()
    nan[0, 0] = np.nan
    assert scale_unchecked(scaler, nan) is None                # scikit-learn's NaN handling
    assert scale_unchecked(StandardScaler(with_mean=False).fit(F), F) is None


def test_minirocket_numpy_head_equals_sklearn_pipeline():
    pytest.importorskip("aeon")
    from terrain.models.minirocket import MiniRocketPipeline, make_minirocket

    X, y = _windows(n_per_class=8)
    X = X.astype(np.float32)
    model = make_minirocket(0, n_kernels=840, max_dilations_per_kernel=8).fit(X, y)
    assert isinstance(model, MiniRocketPipeline) and model._compiled() is not None
    assert model.named_steps["minirocket"].rocket_.max_dilations_per_kernel == 8
    reference = Pipeline(model.steps)                         # scikit-learn's own path
    np.testing.assert_array_equal(model.predict_proba(X), reference.predict_proba(X))
    for i in range(3):
        np.testing.assert_array_equal(model.predict_proba(X[i:i + 1]),
                                      reference.predict_proba(X[i:i + 1]))
    np.testing.assert_array_equal(model.predict(X), reference.predict(X))
    assert clone(model).get_params()["minirocket__max_dilations_per_kernel"] == 8
    binary = make_minirocket(0, n_kernels=84).fit(X[y != "T2"], y[y != "T2"])
    assert binary._compiled() is None                         # scikit-learn's path
    np.testing.assert_array_equal(binary.predict_proba(X),
                                  Pipeline(binary.steps).predict_proba(X))
