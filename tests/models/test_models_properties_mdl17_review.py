"""Invariants of the window classifiers as properties (Hypothesis).

Metrics: scikit-learn's values, unchanged by renaming the classes or reordering the windows.
Weights: the documented ``n(class) / (n_runs(class) n(run))`` and the CNN loss's balanced
class weights. CNNs: rows of ``predict_proba`` sum to 1 and a window's probabilities do not
depend on the other windows of its batch nor on a pickle round trip. Spectra: a slow
frame-by-frame reference. Ensemble: a convex combination of its members. Compiled paths:
scikit-learn's probabilities.
"""

from __future__ import annotations

import pickle
import warnings
from math import comb

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.ensemble import ExtraTreesClassifier, RandomForestClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import (accuracy_score, balanced_accuracy_score, confusion_matrix,
                             f1_score)
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from scipy.signal import get_window
from sklearn.utils.class_weight import compute_class_weight

from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier, log_spectrogram
from terrain.models.ensemble import SoftVotingEnsemble, normalised_weights, simplex_grid
from terrain.models.forest import ForestPipeline
from terrain.models.metrics import confusion, majority_vote, window_metrics
from terrain.models.minirocket import softmax_logistic_proba
from terrain.models.weighting import RunBalancedClassifier, within_class_run_weights

FAST = settings(max_examples=40, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])
#: tiny networks (the library defaults are the measured ones)
TINY = dict(max_epochs=2, width=4, batch_size=16, n_threads=1, device="cpu")
LABELS = ["ASPHALT", "GRASS", "ICE", "SNOW"]


@st.composite
def predictions(draw, min_n: int = 1, max_n: int = 30):
    """True and predicted labels over 2-4 classes (a class may be absent from either)."""
    k = draw(st.integers(2, 4))
    n = draw(st.integers(min_n, max_n))
    y_true = draw(st.lists(st.sampled_from(LABELS[:k]), min_size=n, max_size=n))
    y_pred = draw(st.lists(st.sampled_from(LABELS[:k]), min_size=n, max_size=n))
    return np.asarray(y_true), np.asarray(y_pred), LABELS[:k]


# ---------------------------------------------------------------------------- metrics


@FAST
@given(predictions(), st.data())
def test_window_metrics_are_unchanged_by_renaming_the_classes(case, data):
    y_true, y_pred, classes = case
    renamed = dict(zip(classes, data.draw(st.permutations([c.lower() for c in classes]))))
    rename = np.vectorize(renamed.get)
    before = window_metrics(y_true, y_pred, classes)
    after = window_metrics(rename(y_true), rename(y_pred), [renamed[c] for c in classes])
    for key in ("accuracy", "balanced_accuracy", "macro_f1"):
        assert after[key] == pytest.approx(before[key], abs=1e-12)
    for c in classes:
        assert (f"recall_{c}" in before) == (f"recall_{renamed[c]}" in after)
        if f"recall_{c}" in before:
            assert after[f"recall_{renamed[c]}"] == pytest.approx(before[f"recall_{c}"])


@FAST
@given(predictions(), st.data())
def test_window_metrics_and_confusion_are_scikit_learns_whatever_the_window_order(case, data):
    y_true, y_pred, classes = case
    order = np.asarray(data.draw(st.permutations(range(len(y_true)))))
    got = window_metrics(y_true[order], y_pred[order], classes)
    assert got["accuracy"] == pytest.approx(accuracy_score(y_true, y_pred))
    assert got["macro_f1"] == pytest.approx(f1_score(y_true, y_pred, average="macro",
                                                     zero_division=0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # "y_pred contains classes not in y_true"
        assert got["balanced_accuracy"] == pytest.approx(balanced_accuracy_score(y_true,
                                                                                 y_pred))
    cm = confusion(y_true[order], y_pred[order], classes)
    np.testing.assert_array_equal(cm.to_numpy(), confusion_matrix(y_true, y_pred,
                                                                  labels=classes))
    assert cm.to_numpy().sum() == len(y_true)


@FAST
@given(predictions(), st.lists(st.sampled_from(["r0", "r1", "r2"]), min_size=30, max_size=30))
def test_majority_vote_is_the_most_frequent_label_first_alphabetically_on_a_tie(case, runs):
    _, y_pred, _ = case
    groups = np.asarray(runs[:len(y_pred)])
    vote = majority_vote(y_pred, groups)
    assert list(vote.index) == sorted(set(groups))
    for g in vote.index:
        labels, counts = np.unique(y_pred[groups == g], return_counts=True)
        assert vote[g] == min(labels[counts == counts.max()])


# ---------------------------------------------------------------------------- weights


@st.composite
def run_layouts(draw):
    """Labels and runs of shuffled windows: 1-3 classes of 1-3 runs of 1-5 windows."""
    labels, groups = [], []
    for c in range(draw(st.integers(1, 3))):
        for r in range(draw(st.integers(1, 3))):
            n = draw(st.integers(1, 5))
            labels += [f"T{c}"] * n
            groups += [f"T{c}/{r}"] * n
    order = draw(st.permutations(range(len(labels))))
    return np.asarray(labels)[order], np.asarray(groups)[order]


@FAST
@given(run_layouts(), st.data())
def test_run_weights_are_the_documented_formula_and_follow_their_windows(layout, data):
    labels, groups = layout
    w = within_class_run_weights(labels, groups)
    for i in range(len(labels)):
        in_class = labels == labels[i]
        n_runs = len(set(groups[in_class]))
        expected = in_class.sum() / (n_runs * (groups == groups[i]).sum())
        assert w[i] == pytest.approx(expected, rel=1e-12)
    order = np.asarray(data.draw(st.permutations(range(len(labels)))))
    np.testing.assert_allclose(within_class_run_weights(labels[order], groups[order]),
                               w[order], rtol=1e-12)


class _Recorder(ClassifierMixin, BaseEstimator):
    """Records the weights its ``fit`` is given; predicts the first class."""

    def fit(self, X, y, sample_weight=None):
        self.classes_ = np.unique(y)
        self.sample_weight_ = sample_weight
        return self

    def predict_proba(self, X):
        out = np.zeros((len(X), len(self.classes_)))
        out[:, 0] = 1.0
        return out


@FAST
@given(run_layouts())
def test_run_balanced_classifier_fits_with_the_run_weights(layout):
    labels, groups = layout
    X = np.zeros((len(labels), 2))
    model = RunBalancedClassifier(_Recorder()).fit(X, labels, groups)
    np.testing.assert_array_equal(model.estimator_.sample_weight_,
                                  within_class_run_weights(labels, groups))


# ---------------------------------------------------------------------------- CNNs


def _tone_windows(n_per_class: int = 8, n_channels: int = 2, n_samples: int = 40,
                  seed: int = 0):
    """Class ``Tk`` adds a ``10 (k + 1)`` Hz tone to channel 0 (100 Hz clock)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_samples) / 100.0
    X, y, runs = [], [], []
    for k in range(3):
        for i in range(n_per_class):
            w = rng.normal(0.0, 1.0, (n_channels, n_samples))
            w[0] += 2.0 * np.sin(2 * np.pi * 10.0 * (k + 1) * t)
            X.append(w)
            y.append(f"T{k}")
            runs.append(f"T{k}/{i % 2}")
    return np.asarray(X, dtype=np.float32), np.asarray(y), np.asarray(runs)


@pytest.fixture(scope="module")
def tiny_cnns():
    X, y, _ = _tone_windows()
    return X, [RawCNNClassifier(**TINY).fit(X, y),
               SpectrogramCNNClassifier(segment_s=0.1, hop_s=0.05, **TINY).fit(X, y)]


@FAST
@given(st.data())
def test_cnn_probabilities_sum_to_one_and_do_not_depend_on_the_batch(tiny_cnns, data):
    X, models = tiny_cnns
    model = models[data.draw(st.integers(0, 1))]
    rows = np.asarray(data.draw(st.lists(st.integers(0, len(X) - 1), min_size=1,
                                         max_size=12)))
    scale = data.draw(st.floats(0.1, 10.0))
    batch = X[rows] * np.float32(scale)
    proba = model.predict_proba(batch)
    assert proba.shape == (len(rows), 3)
    assert (proba >= 0).all()
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-6)
    order = np.asarray(data.draw(st.permutations(range(len(rows)))))
    np.testing.assert_allclose(model.predict_proba(batch[order]), proba[order], atol=1e-6)
    one = model.predict_proba(batch[:1])
    np.testing.assert_allclose(one, proba[:1], atol=1e-6)
    np.testing.assert_array_equal(model.predict(batch),
                                  model.classes_[proba.argmax(axis=1)])


def test_cnns_round_trip_through_pickle_with_identical_predictions(tiny_cnns):
    X, models = tiny_cnns
    for model in models:
        again = pickle.loads(pickle.dumps(model))
        np.testing.assert_array_equal(again.predict_proba(X), model.predict_proba(X))


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_cnn_loss_weights_are_balanced_class_weights_of_the_training_windows(cls):
    X, y, runs = _tone_windows()
    keep = np.r_[0:8, 8:11, 16:21]          # 8, 3 and 5 windows of T0, T1, T2
    extra = dict(segment_s=0.1, hop_s=0.05) if cls is SpectrogramCNNClassifier else {}
    model = cls(**{**TINY, "max_epochs": 1}, **extra).fit(X[keep], y[keep])
    weight = model.net_.criterion__weight.numpy()
    np.testing.assert_allclose(weight, compute_class_weight(
        "balanced", classes=model.classes_, y=y[keep]), rtol=1e-6)


def _slow_log_spectrogram(x: np.ndarray, rate_hz: float, segment_s: float, hop_s: float):
    """Frame by frame: every ``hop``-th segment of ``seg`` samples, the last ending at the
    newest sample, tapered (periodic Hann), its power."""
    seg = int(np.clip(round(segment_s * rate_hz), 2, len(x)))
    hop = max(1, int(round(hop_s * rate_hz)))
    taper = get_window("hann", seg) if seg >= 4 else np.ones(seg)   # (3 samples too, mdl23)
    cols = []
    for start in range((len(x) - seg) % hop, len(x) - seg + 1, hop):
        spec = np.fft.rfft(x[start:start + seg] * taper)
        cols.append(np.log10(np.abs(spec) ** 2 + 1e-10))
    return np.asarray(cols).T


@FAST
@given(arrays(np.float32, st.tuples(st.integers(1, 2), st.integers(1, 2), st.integers(2, 40)),
              elements=st.floats(-100, 100, width=32)),
       st.sampled_from([50.0, 100.0]), st.floats(0.02, 0.6), st.floats(0.005, 0.3))
def test_log_spectrogram_is_the_frame_by_frame_power(X, rate_hz, segment_s, hop_s):
    spectra, freqs = log_spectrogram(X, rate_hz, segment_s, hop_s)
    for i in range(X.shape[0]):
        for c in range(X.shape[1]):
            ref = _slow_log_spectrogram(X[i, c].astype(np.float64), rate_hz, segment_s, hop_s)
            # compared as powers: a bin that is exactly 0 (a constant through the periodic
            # Hann taper has power in bins 0 and 1 only) is float32 rounding, 1e-8 of the
            # frame's amplitude, and its log sits anywhere near the floor
            np.testing.assert_allclose(10.0 ** spectra[i, c], 10.0 ** ref, rtol=5e-3,
                                       atol=1e-6 * 10.0 ** ref.max())
    seg = int(np.clip(round(segment_s * rate_hz), 2, X.shape[-1]))
    np.testing.assert_allclose(freqs, np.arange(seg // 2 + 1) * rate_hz / seg)


# ---------------------------------------------------------------------------- ensemble


class _Fixed(ClassifierMixin, BaseEstimator):
    """Probabilities ``softmax(X @ coef)`` over its classes (a member of known output)."""

    def __init__(self, classes=("A", "B"), seed=0):
        self.classes = classes
        self.seed = seed

    def fit(self, X, y, groups=None):
        self.classes_ = np.asarray(self.classes)
        shape = (X.shape[1], len(self.classes))
        self.coef_ = np.random.default_rng(self.seed).normal(size=shape)
        return self

    def predict_proba(self, X):
        z = np.asarray(X) @ self.coef_
        z = np.exp(z - z.max(axis=1, keepdims=True))
        return z / z.sum(axis=1, keepdims=True)


@FAST
@given(st.lists(st.floats(0.0, 5.0), min_size=3, max_size=3).filter(lambda w: sum(w) > 1e-3),
       arrays(np.float64, st.tuples(st.integers(1, 6), st.just(2)),
              elements=st.floats(-3, 3)), st.permutations(range(3)))
def test_ensemble_is_the_weighted_mean_of_its_members_whatever_their_order(weights, X, order):
    members = [("m0", _Fixed(("A", "B", "C"), 0)), ("m1", _Fixed(("A", "C"), 1)),
               ("m2", _Fixed(("B", "C"), 2))]
    y = np.array(["A", "B", "C"] * 2)
    fitted = SoftVotingEnsemble(members, weights=weights).fit(np.zeros((6, 2)), y)
    proba = fitted.predict_proba(X)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-12)
    w = np.asarray(weights) / sum(weights)
    expected = np.zeros((len(X), 3))
    for wi, (_, est) in zip(w, members):
        cols = [["A", "B", "C"].index(c) for c in est.classes]
        expected[:, cols] += wi * est.fit(X, None).predict_proba(X)
    np.testing.assert_allclose(proba, expected, atol=1e-12)
    shuffled = SoftVotingEnsemble([members[i] for i in order],
                                  weights=[weights[i] for i in order]).fit(np.zeros((6, 2)), y)
    np.testing.assert_allclose(shuffled.predict_proba(X), proba, atol=1e-12)


@FAST
@given(st.integers(1, 4), st.sampled_from([1.0, 0.5, 0.25, 0.2, 0.1]))
def test_simplex_grid_is_every_composition_of_the_step(n_members, step):
    grid = simplex_grid(n_members, step)
    k = round(1 / step)
    assert grid.shape == (comb(k + n_members - 1, n_members - 1), n_members)
    np.testing.assert_allclose(grid.sum(axis=1), 1.0)
    assert (grid >= 0).all() and len({tuple(r) for r in grid}) == len(grid)
    np.testing.assert_allclose(grid * k, np.round(grid * k), atol=1e-9)


@FAST
@given(st.lists(st.floats(0.0, 1e6), min_size=1, max_size=5).filter(lambda w: sum(w) > 0))
def test_normalised_weights_keep_the_ratios_and_sum_to_one(w):
    out = normalised_weights(w, len(w))
    assert out.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(out * sum(w), w, rtol=1e-9, atol=1e-9)


# ---------------------------------------------------------------------------- compiled


@pytest.mark.slow
@FAST
@given(st.integers(0, 2 ** 16), st.sampled_from([ExtraTreesClassifier, RandomForestClassifier]),
       st.floats(0.0, 0.3))
def test_forest_pipeline_compiled_path_is_scikit_learns(seed, forest, nan_share):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(40, 3))
    y = np.where(X[:, 0] + 0.3 * rng.normal(size=40) > 0, "A", "B")
    y[:3] = "C"
    steps = [("scale", StandardScaler()),
             ("forest", forest(n_estimators=5, random_state=seed % 7, max_depth=4))]
    fast, ref = ForestPipeline(steps).fit(X, y), Pipeline(steps).fit(X, y)
    Xt = rng.normal(size=(12, 3)) * 3
    Xt[rng.random(Xt.shape) < nan_share] = np.nan
    fast_proba = fast.predict_proba(Xt)
    assert fast._compiled() is not None
    np.testing.assert_allclose(fast_proba, ref.predict_proba(Xt), rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast_proba.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_array_equal(fast.predict(Xt), ref.predict(Xt))
    again = pickle.loads(pickle.dumps(fast))
    np.testing.assert_array_equal(again.predict_proba(Xt), fast_proba)


@FAST
@given(st.integers(0, 2 ** 16), st.integers(3, 5))
def test_numpy_softmax_is_the_logistic_regressions_probabilities(seed, k):
    rng = np.random.default_rng(seed)
    Z = rng.normal(size=(30, 4))
    y = np.arange(30) % k
    logreg = LogisticRegression(max_iter=200).fit(Z, y)
    Zt = rng.normal(size=(7, 4)) * 5
    np.testing.assert_allclose(softmax_logistic_proba(Zt.copy(), logreg),
                               logreg.predict_proba(Zt), rtol=0, atol=1e-12)


@pytest.fixture(scope="module")
def registry_models():
    """The SVM and the equal-weight SVM + spectrogram-CNN vote of the registry, fitted."""
    from terrain.models.registry import ModelConfig, make_model

    X, y, _ = _tone_windows(n_per_class=6, n_samples=40)
    models = []
    for kind in ("svm", "ensemble"):
        config = ModelConfig(kind=kind, max_epochs=1, n_threads=1)
        model = make_model(config, ("ax", "wz"), 100.0, "borealtc", random_state=3)
        models.append(model.fit(X, y))
    return X, models


@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.data())
def test_registry_models_round_trip_and_do_not_depend_on_the_batch(registry_models, data):
    X, models = registry_models
    model = models[data.draw(st.integers(0, 1))]
    rows = np.asarray(data.draw(st.lists(st.integers(0, len(X) - 1), min_size=1,
                                         max_size=8)))
    proba = model.predict_proba(X[rows])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-6)
    order = np.asarray(data.draw(st.permutations(range(len(rows)))))
    np.testing.assert_allclose(model.predict_proba(X[rows][order]), proba[order], atol=1e-9)
    np.testing.assert_allclose(model.predict_proba(X[rows[:1]]), proba[:1], atol=1e-9)
    again = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(again.predict_proba(X[rows]), proba)
    np.testing.assert_array_equal(again.predict(X[rows]), model.predict(X[rows]))
