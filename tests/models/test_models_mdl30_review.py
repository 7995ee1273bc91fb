"""Properties of the newest classifier code (review mdl30): the spectrogram's frame placement,
the CNNs' estimator contract and window weights, the within-class run weights and the
members' renormalised probabilities."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import BaseEstimator, ClassifierMixin, clone

from features.calculators import hann_taper
from terrain.errors import NonFiniteInputError, ShapeError
from terrain.models.cnn import (POWER_FLOOR, RawCNNClassifier, SpectrogramCNNClassifier,
                                log_spectrogram, segment_samples)
from terrain.models.cv import member_probabilities
from terrain.models.ensemble import SoftVotingEnsemble, aligned_proba
from terrain.models.weighting import run_shares, within_class_run_weights

TINY = dict(max_epochs=2, batch_size=4, width=2, n_threads=1, device="cpu")
RATES_HZ = (5.0, 6.5, 10.0, 20.0, 50.0, 100.0)


def _reference_spectra(x: np.ndarray, seg: int, hop: int) -> np.ndarray:
    """``(n_freqs, n_frames)`` log power of one channel, frames ending at the newest sample,
    spelt out frame by frame (the last frame is ``x[n - seg:]``, each earlier one ``hop``
    samples before it, as long as it fits in the window)."""
    n = x.size
    taper = hann_taper(seg) if seg >= 4 else np.ones(seg)
    ends = list(range(n, seg - 1, -hop))[::-1]
    cols = [np.log10(np.abs(np.fft.rfft(x[e - seg:e] * taper)) ** 2 + POWER_FLOOR)
            for e in ends]
    return np.stack(cols, axis=-1)


# -- log_spectrogram ------------------------------------------------------------------------

@settings(max_examples=80, deadline=None)
@given(n=st.integers(1, 90), rate=st.sampled_from(RATES_HZ),
       segment_s=st.sampled_from((0.1, 0.25, 0.5, 1.0, 3.0)),
       hop_s=st.sampled_from((0.01, 0.1, 0.2, 0.5, 2.0)), seed=st.integers(0, 2 ** 16))
def test_every_frame_is_the_segment_ending_hops_before_the_newest_sample(
        n, rate, segment_s, hop_s, seed):
    x = np.random.default_rng(seed).normal(size=(1, 2, n))
    spectra, freqs = log_spectrogram(x, rate, segment_s, hop_s)
    seg = segment_samples(rate, segment_s, n)
    hop = max(1, int(round(hop_s * rate)))
    assert spectra.shape == (1, 2, seg // 2 + 1, (n - seg) // hop + 1)
    np.testing.assert_allclose(freqs, np.arange(seg // 2 + 1) * rate / seg)
    for c in range(2):
        np.testing.assert_allclose(spectra[0, c], _reference_spectra(x[0, c], seg, hop),
                                   atol=2e-4)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(2, 90), rate=st.sampled_from(RATES_HZ),
       segment_s=st.sampled_from((0.1, 0.25, 0.5, 1.0)),
       hop_s=st.sampled_from((0.1, 0.2, 0.5)), seed=st.integers(0, 2 ** 16))
def test_the_newest_sample_always_reaches_the_spectra_and_only_the_oldest_are_unseen(
        n, rate, segment_s, hop_s, seed):
    x = np.random.default_rng(seed).normal(size=(1, 1, n))
    seg = segment_samples(rate, segment_s, n)
    hop = max(1, int(round(hop_s * rate)))
    unseen = (n - seg) % hop
    base = log_spectrogram(x, rate, segment_s, hop_s)[0]
    newest = x.copy()
    newest[..., -1] += 10.0
    assert not np.array_equal(log_spectrogram(newest, rate, segment_s, hop_s)[0][..., -1],
                              base[..., -1])
    oldest = x.copy()
    oldest[..., :unseen] += 10.0
    np.testing.assert_array_equal(log_spectrogram(oldest, rate, segment_s, hop_s)[0], base)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 60), n_channels=st.integers(1, 4), rate=st.sampled_from(RATES_HZ),
       seed=st.integers(0, 2 ** 16))
def test_each_channel_spectrum_depends_on_its_own_channel_only(n, n_channels, rate, seed):
    x = np.random.default_rng(seed).normal(size=(3, n_channels, n)).astype(np.float32)
    together = log_spectrogram(x, rate, 0.5, 0.2)[0]
    for c in range(n_channels):
        alone = log_spectrogram(x[:, c:c + 1], rate, 0.5, 0.2)[0]
        np.testing.assert_array_equal(together[:, c:c + 1], alone)


def test_a_window_shorter_than_one_segment_is_one_frame_of_the_whole_window():
    x = np.random.default_rng(1).normal(size=(2, 1, 7))
    spectra, freqs = log_spectrogram(x, 100.0, 0.5, 0.2)     # 50-sample segments, 7 samples
    assert spectra.shape == (2, 1, 4, 1) and freqs.size == 4
    np.testing.assert_allclose(spectra[1, 0], _reference_spectra(x[1, 0], 7, 20), atol=2e-4)


# -- the CNNs' estimator contract and window weights ----------------------------------------

def _windows(n_runs: int = 6, per_run: int = 2, n_samples: int = 24, seed: int = 0):
    rng = np.random.default_rng(seed)
    y = np.repeat(np.array(list("ab") * (n_runs // 2)), per_run)
    X = rng.normal(size=(y.size, 2, n_samples)).astype(np.float32)
    X[y == "b", 0] += 1.0
    groups = np.repeat(np.arange(n_runs), per_run)
    return X, y, groups


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_clone_and_set_params_round_trip_and_refit_the_same_model(cls):
    X, y, _ = _windows()
    model = cls(**TINY, random_state=3)
    copy = clone(model).set_params(**model.get_params())
    assert copy.get_params() == model.get_params()
    np.testing.assert_array_equal(model.fit(X, y).predict_proba(X),
                                  copy.fit(X, y).predict_proba(X))
    assert list(model.classes_) == ["a", "b"]


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_the_scaling_comes_from_the_training_windows_only(cls):
    X, y, _ = _windows()
    model = cls(**TINY).fit(X[:8], y[:8])
    mean, scale = model.mean_.copy(), model.scale_.copy()
    model.predict_proba(X[8:] * 100.0)
    np.testing.assert_array_equal(model.mean_, mean)
    np.testing.assert_array_equal(model.scale_, scale)
    Z = model._inputs(X[:8].astype(np.float32))
    axes = (0,) + tuple(range(2 + model._per_bin, Z.ndim))
    np.testing.assert_allclose(model.mean_, Z.mean(axis=axes, dtype=np.float64)
                               .reshape(model.mean_.shape), rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_runs_held_out_for_early_stopping_take_no_part_in_the_scaling(cls):
    X, y, groups = _windows(n_runs=8)
    X[np.isin(groups, [0, 1, 2, 3])] *= 1 + groups[np.isin(groups, [0, 1, 2, 3]), None, None]
    model = cls(**TINY, early_stopping=True, validation_splits=2, patience=1).fit(X, y, groups)
    train = ~np.isin(groups, model.validation_groups_)
    assert 0 < train.sum() < y.size
    Z = model._inputs(X[train])
    axes = (0,) + tuple(range(2 + model._per_bin, Z.ndim))
    np.testing.assert_allclose(model.mean_, Z.mean(axis=axes, dtype=np.float64)
                               .reshape(model.mean_.shape), rtol=1e-5, atol=1e-5)


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), power=st.integers(-3, 3))
def test_same_seed_and_weights_give_the_same_model_whatever_their_scale(seed, power):
    X, y, groups = _windows()
    w = within_class_run_weights(y, groups) * np.arange(1, y.size + 1)
    fit = (lambda weights: RawCNNClassifier(**TINY, random_state=seed)
           .fit(X, y, sample_weight=weights).predict_proba(X))
    first = fit(w)
    np.testing.assert_array_equal(first, fit(w))
    np.testing.assert_array_equal(first, fit(w * 2.0 ** power))     # the sampler normalises
    np.testing.assert_allclose(first.sum(axis=1), 1.0, rtol=0, atol=4 * np.finfo(float).eps)


@pytest.mark.parametrize("weights", [2.0, np.ones((12, 2)), np.ones(11), np.ones(13)])
def test_sample_weight_of_another_shape_is_a_shape_error_naming_it(weights):
    X, y, _ = _windows()
    with pytest.raises(ShapeError, match="sample_weight"):
        RawCNNClassifier(**TINY).fit(X, y, sample_weight=weights)


@pytest.mark.parametrize("weights, error, match", [
    (np.full(12, np.nan), NonFiniteInputError, "sample_weight must be finite"),
    (np.r_[np.inf, np.ones(11)], NonFiniteInputError, "sample_weight must be finite"),
    (np.r_[-1.0, np.ones(11)], ValueError, "sample_weight must be finite and >= 0"),
    (np.zeros(12), ValueError, "not all zero"),
    (np.ones(12, dtype=bool), ValueError, "booleans"),
    (np.array(["1"] * 12), ValueError, "must hold numbers"),
])
def test_bad_sample_weight_values_are_refused_before_any_training(weights, error, match):
    X, y, _ = _windows()
    model = RawCNNClassifier(**TINY)
    with pytest.raises(error, match=match):
        model.fit(X, y, sample_weight=weights)
    assert not hasattr(model, "net_")


# -- within-class run weights ---------------------------------------------------------------

_runs = st.lists(st.tuples(st.sampled_from("abc"), st.integers(0, 5)), min_size=1,
                 max_size=40)


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(rows=_runs, seed=st.integers(0, 2 ** 16))
def test_every_run_of_a_class_weighs_the_same_and_each_class_keeps_its_total(rows, seed):
    labels = np.array([c for c, _ in rows])
    groups = np.array([r for _, r in rows])
    w = within_class_run_weights(labels, groups)
    assert w.shape == labels.shape and (w > 0).all()
    for c in np.unique(labels):
        in_class = labels == c
        np.testing.assert_allclose(w[in_class].sum(), in_class.sum(), rtol=1e-12)
        runs = np.unique(groups[in_class])
        totals = [w[in_class & (groups == r)].sum() for r in runs]
        np.testing.assert_allclose(totals, in_class.sum() / runs.size, rtol=1e-12)
        if runs.size == 1:
            np.testing.assert_array_equal(w[in_class], 1.0)
    # order of the windows, names of the runs (bijective), ints or text: the same weights
    order = np.random.default_rng(seed).permutation(labels.size)
    np.testing.assert_allclose(within_class_run_weights(labels[order], groups[order]),
                               w[order], rtol=1e-12)
    renamed = np.array([f"run-{(7 * r + 3) % 11}" for r in groups])
    np.testing.assert_array_equal(within_class_run_weights(labels, renamed), w)
    np.testing.assert_array_equal(within_class_run_weights(list(labels), list(groups)), w)


@settings(max_examples=40, deadline=None)
@given(n_runs=st.integers(1, 8))
def test_one_window_per_run_weighs_one(n_runs):
    labels = np.array(["x"] * n_runs + ["y"] * n_runs)
    groups = np.arange(2 * n_runs)
    np.testing.assert_array_equal(within_class_run_weights(labels, groups), 1.0)


@pytest.mark.parametrize("missing", [pd.NA, np.datetime64("NaT"), np.float32("nan"),
                                     float("nan"), None])
@pytest.mark.parametrize("name", ["labels", "groups"])
def test_a_missing_label_or_run_of_any_kind_is_refused(missing, name):
    values = {"labels": np.array(["a", "a", "b"], dtype=object),
              "groups": np.array(["r", "s", "t"], dtype=object)}
    values[name][1] = missing
    with pytest.raises(NonFiniteInputError, match=rf"{name} holds 1 missing.*index 1"):
        run_shares(values["labels"], values["groups"])
    with pytest.raises(NonFiniteInputError, match=name):
        within_class_run_weights(values["labels"], values["groups"])


def test_a_missing_run_on_a_time_axis_is_refused_not_weighted_from_unset_memory():
    groups = np.array(["2020-01-01", "NaT", "2020-01-02"], dtype="datetime64[ns]")
    with pytest.raises(NonFiniteInputError, match="groups holds 1 missing.*index 1"):
        within_class_run_weights(["a", "a", "a"], groups)


# -- members' probabilities -----------------------------------------------------------------

@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2 ** 16), n_classes=st.integers(2, 9), n=st.integers(1, 30))
def test_member_rows_sum_to_one_in_float64_and_keep_their_ranking(seed, n_classes, n):
    raw = np.random.default_rng(seed).dirichlet(np.full(n_classes, 0.3), n).astype(np.float32)
    out = member_probabilities(raw)
    assert out.dtype == np.float64 and (out >= 0).all() and (out <= 1).all()
    np.testing.assert_allclose(out.sum(axis=1), 1.0, rtol=0, atol=4 * np.finfo(float).eps)
    np.testing.assert_array_equal(out.argmax(axis=1), raw.argmax(axis=1))


class _Fixed(ClassifierMixin, BaseEstimator):
    """A fitted member that knows some classes only (float32 rows, as MiniRocket's)."""

    def __init__(self, classes=(), proba=()):
        self.classes = classes
        self.proba = proba
        self.classes_ = np.asarray(classes)

    def predict_proba(self, X):
        return np.asarray(self.proba, dtype=np.float32)


def test_a_member_missing_a_class_gives_it_zero_and_its_rows_still_sum_to_one():
    member = _Fixed(["c", "a"], [[0.3, 0.7], [1.0, 0.0]])
    out = aligned_proba(member, None, np.array(["a", "b", "c"]))
    np.testing.assert_allclose(out, [[0.7, 0.0, 0.3], [0.0, 0.0, 1.0]], atol=1e-7)
    np.testing.assert_allclose(out.sum(axis=1), 1.0, rtol=0, atol=2 * np.finfo(float).eps)
    other = _Fixed(["a", "b", "c"], [[0.2, 0.3, 0.5]] * 2)
    ensemble = SoftVotingEnsemble([("m", member), ("n", other)], weights=(1.0, 1.0))
    ensemble.classes_ = np.array(["a", "b", "c"])
    ensemble.estimators_ = [e for _, e in ensemble.estimators]
    ensemble.weights_ = np.array([0.5, 0.5])
    proba = ensemble.predict_proba(None)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, rtol=0, atol=4 * np.finfo(float).eps)
    np.testing.assert_allclose(proba[0], [0.45, 0.15, 0.4], atol=1e-7)


def test_a_fold_trained_without_a_class_scores_it_zero_and_its_rows_sum_to_one():
    from sklearn.linear_model import LogisticRegression

    from terrain.models.cv import cross_validate

    class Float32Member(LogisticRegression):
        def predict_proba(self, X):
            return super().predict_proba(X).astype(np.float32)

    runs = [("a", f"a{i}") for i in range(3)] + [("b", f"b{i}") for i in range(3)] + \
        [("c", "c0")]       # c has one run: the folds that test it train without it
    y = np.repeat([label for label, _ in runs], 4)
    groups = np.repeat([run for _, run in runs], 4)
    t = np.tile(np.arange(4.0), len(runs))
    X = np.random.default_rng(0).normal(size=(y.size, 3))
    report = cross_validate(lambda seed: Float32Member(), X, y, groups, groups, t, t + 1.0,
                            seeds=(0,), n_splits=3)
    proba = report.predictions[["proba_a", "proba_b", "proba_c"]].to_numpy()
    assert proba.dtype == np.float64
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, rtol=0, atol=4 * np.finfo(float).eps)
    assert (proba[:, 2] == 0).any()     # a fold without c gives it 0 in its column


def test_a_seeded_spectrogram_cnn_with_noise_copies_and_weights_is_reproducible():
    X, y, groups = _windows(n_samples=30)
    w = within_class_run_weights(y, groups)
    fit = (lambda: SpectrogramCNNClassifier(**TINY, rate_hz=20.0, augment_noise_std=0.3,
                                            random_state=5)
           .fit(X, y, sample_weight=w).predict_proba(X))
    np.testing.assert_array_equal(fit(), fit())


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_labels_renamed_in_the_same_order_and_runs_as_text_train_the_same_network(cls):
    from terrain.models.weighting import run_balanced

    X, y, groups = _windows()
    base = run_balanced(cls(**TINY, random_state=1)).fit(X, y, groups)
    named = np.where(y == "a", 10, 20)                      # a < b as 10 < 20
    renamed = run_balanced(cls(**TINY, random_state=1)).fit(X, named, groups.astype(str))
    np.testing.assert_array_equal(base.predict_proba(X), renamed.predict_proba(X))
    assert list(renamed.classes_) == [10, 20]
    np.testing.assert_array_equal(renamed.predict(X), np.where(base.predict(X) == "a", 10, 20))


@pytest.mark.parametrize("X", [np.ones((2, 1, 0)), np.ones(0), np.float64(1.0)])
def test_windows_of_no_sample_are_a_shape_error_not_numpys_fft_refusal(X):
    with pytest.raises(ShapeError, match="hold no sample"):
        log_spectrogram(X, 10.0, 0.5, 0.2)


def test_windows_given_as_nested_lists_are_read_as_an_array():
    x = [[[0.0, 1.0, 0.5, -1.0, 2.0]]]
    np.testing.assert_array_equal(log_spectrogram(x, 10.0, 0.5, 0.2)[0],
                                  log_spectrogram(np.asarray(x), 10.0, 0.5, 0.2)[0])


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2 ** 16), n_members=st.integers(1, 9),
       certain=st.booleans())
def test_a_soft_vote_of_float32_members_stays_a_distribution(seed, n_members, certain):
    rng = np.random.default_rng(seed)
    classes = np.array(["a", "b", "c"])
    members = []
    for k in range(n_members):
        known = classes[np.sort(rng.choice(3, size=rng.integers(2, 4), replace=False))]
        proba = rng.dirichlet(np.full(known.size, 0.5), 5)
        if certain:      # every member certain of class "a" where it knows it
            proba = np.eye(known.size)[np.zeros(5, dtype=int)]
        members.append((f"m{k}", _Fixed(rng.permutation(known) if not certain else known,
                                        proba)))
    ensemble = SoftVotingEnsemble(members, weights=tuple(rng.uniform(0.1, 1.0, n_members)))
    ensemble.classes_ = classes
    ensemble.estimators_ = [m for _, m in members]
    ensemble.weights_ = np.asarray(ensemble.weights) / np.sum(ensemble.weights)
    proba = ensemble.predict_proba(None)
    assert proba.dtype == np.float64 and (proba >= 0).all() and (proba <= 1).all()
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, rtol=0, atol=8 * np.finfo(float).eps)
