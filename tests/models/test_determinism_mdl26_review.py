"""Determinism of the models' fits and probabilities (review mdl26): the same seed gives
bit-identical results however the fits are scheduled (threads, processes, pickles)."""

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("skorch")

import torch  # noqa: E402
from joblib import Parallel, delayed  # noqa: E402

from terrain.models.cnn import RawCNNClassifier  # noqa: E402


def _windows(n=32, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 2, 24)).astype(np.float32)
    y = np.array(["a", "b"] * (n // 2))
    X[y == "b"] += 0.5
    groups = np.repeat(np.arange(n // 4), 4).astype(str)
    return X, y, groups


def _proba(seed, X, y, n_threads=1, **kw):
    model = RawCNNClassifier(max_epochs=2, batch_size=8, width=4, dropout=0.2,
                             random_state=seed, n_threads=n_threads, **kw)
    return model.fit(X, y).predict_proba(X)


def test_cnn_fits_in_threads_equal_sequential_fits():
    """The threading backend (cross_validate and the compare grid run folds through joblib)
    ran CNN fits concurrently on torch's one global RNG: each fit seeded it, and the other
    fit's weight initialisation and dropout drew from it in between, so a seed's fold
    moved by up to 0.2 in probability between the sequential and the threading backend."""
    X, y, _ = _windows()
    seeds = [0, 1, 2]
    alone = [_proba(s, X, y) for s in seeds]
    threaded = Parallel(n_jobs=3, backend="threading")(
        delayed(_proba)(s, X, y) for s in seeds)
    for a, b in zip(alone, threaded):
        np.testing.assert_array_equal(a, b)


# ---- probabilities after averaging: in [0, 1], rows summing to 1 -------------------------

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from sklearn.dummy import DummyClassifier  # noqa: E402
from sklearn.metrics import brier_score_loss, log_loss  # noqa: E402

from terrain.models.ensemble import SoftVotingEnsemble  # noqa: E402


def test_nine_certain_members_average_to_probability_one_not_above():
    """Nine members of weight 1/9 each certain of a window: the weighted sum rounded to
    1.0000000000000002, which scikit-learn's log_loss and brier_score_loss refuse ("y_prob
    contains values greater than 1"); a bag of nine CNNs (cnn_seeds=9) is such an
    ensemble."""
    X = np.zeros((6, 2))
    y = np.array(["a", "a", "a", "a", "b", "b"])
    members = [(f"m{i}", DummyClassifier(strategy="most_frequent")) for i in range(9)]
    proba = SoftVotingEnsemble(members, weights=(1.0,) * 9).fit(X, y).predict_proba(X)
    assert proba.max() <= 1.0
    log_loss(y, proba, labels=["a", "b"])
    brier_score_loss(y, proba[:, 1], pos_label="b")


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(1, 50), min_size=2, max_size=10),
       st.lists(st.sampled_from(["most_frequent", "prior", "uniform"]), min_size=10,
                max_size=10))
def test_ensemble_probabilities_stay_in_unit_interval(weights, strategies):
    X = np.zeros((7, 1))
    y = np.array(["a", "a", "b", "c", "c", "c", "c"])
    members = [(f"m{i}", DummyClassifier(strategy=s))
               for i, s in zip(range(len(weights)), strategies)]
    proba = SoftVotingEnsemble(members, weights=[float(w) for w in weights]).fit(
        X, y).predict_proba(X)
    assert ((proba >= 0) & (proba <= 1)).all()
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, rtol=0, atol=4e-16)


def test_soft_vote_of_nine_certain_members_stays_at_one():
    """soft_vote (the grid's out-of-fold ensemble) is SoftVotingEnsemble's average: nine
    certain members gave it 1.0000000000000002 too."""
    import pandas as pd

    from terrain.models.compare import soft_vote

    frame = pd.DataFrame({"seed": 0, "fold": 0, "run": ["r1", "r2"], "t_start_s": [0.0, 1.0],
                          "true": ["a", "b"], "predicted": ["a", "b"],
                          "proba_a": [1.0, 0.0], "proba_b": [0.0, 1.0]})
    out = soft_vote([frame] * 9, ["a", "b"])
    assert out[["proba_a", "proba_b"]].to_numpy().max() <= 1.0
    assert list(out["predicted"]) == ["a", "b"]


def test_cnn_probability_rows_sum_to_one_in_float64():
    """The softmax was computed in float32 and handed out as float64: rows summed to 1 only
    within ~1e-7, outside scikit-learn's tolerance (sqrt of float64's eps), so log_loss and
    brier_score_loss warned "The y_prob values do not sum to one" on a CNN's output."""
    import warnings

    X, y, _ = _windows(n=64, seed=3)
    model = RawCNNClassifier(max_epochs=2, batch_size=8, width=4, n_threads=1).fit(X, y)
    for batch in (X, np.concatenate([X] * 2)):      # both inference paths (<= and > 64)
        proba = model.predict_proba(batch)
        np.testing.assert_allclose(proba.sum(axis=1), 1.0, rtol=0, atol=4e-16)
        assert ((proba >= 0) & (proba <= 1)).all()
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            log_loss(np.concatenate([y] * (len(batch) // len(y))), proba, labels=["a", "b"])
    # the decisions are those of the float32 softmax (a row is divided by its own sum)
    assert (model.predict(X) == model.classes_[proba[:len(X)].argmax(axis=1)]).all()


# ---- the same seed, the same bits ----------------------------------------------------------

def test_cnn_fit_after_another_fit_equals_the_fit_alone_and_survives_pickling():
    import pickle

    X, y, _ = _windows()
    alone = _proba(5, X, y)
    torch.manual_seed(123)
    expected = torch.rand(3)
    torch.manual_seed(123)
    _proba(9, X, y, n_threads=2)                      # another seed, another thread count
    after = RawCNNClassifier(max_epochs=2, batch_size=8, width=4, dropout=0.2,
                             random_state=5, n_threads=1).fit(X, y)
    np.testing.assert_array_equal(after.predict_proba(X), alone)
    assert torch.equal(torch.rand(3), expected)       # the caller's stream untouched
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(after)).predict_proba(X), alone)
    assert not np.array_equal(_proba(6, X, y), alone)  # the seed is not ignored


class _Float32Proba(DummyClassifier):
    """A member whose probabilities are float32, as MiniRocketPipeline's (scikit-learn's
    LogisticRegression on float32 features): rows sum to 1 within ~1e-7 only."""

    def predict_proba(self, X):
        return np.asarray(super().predict_proba(X), dtype=np.float32)


def test_an_ensemble_with_a_float32_member_sums_to_one_in_float64():
    """A float32 member such as MiniRocket left the ensemble's float64 rows summing to 1
    within ~1e-7 only, which scikit-learn's float64 log_loss warns about; each member's rows
    are now divided by their sum in float64 (in the cross_validate frame too)."""
    import warnings

    X = np.zeros((7, 1))
    y = np.array(["a", "b", "b", "c", "c", "c", "c"])
    ens = SoftVotingEnsemble([("f", _Float32Proba(strategy="prior")),
                              ("g", DummyClassifier(strategy="prior"))], weights=(2.0, 1.0))
    proba = ens.fit(X, y).predict_proba(X)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        log_loss(y, proba, labels=["a", "b", "c"])


def test_a_cross_validate_frame_of_a_float32_member_sums_to_one_in_float64():
    """The cross_validate frame (soft_vote's input, ``merge_compare.py --vote``) held a
    float32 member's rows as they came, summing to 1 within ~1e-7 only."""
    from terrain.models.cv import cross_validate

    rng = np.random.default_rng(0)
    run = np.repeat(np.arange(6), 5)
    y = np.array(["a", "b", "c"])[run % 3]
    X = rng.normal(size=(len(run), 2))
    groups = np.array([f"r{r}" for r in run], dtype=object)
    t0 = np.tile(np.arange(5) * 2.0, 6)
    report = cross_validate(lambda seed: _Float32Proba(strategy="prior"), X, y, groups,
                            groups, t0, t0 + 2.0, protocol="grouped", seeds=(0,),
                            n_splits=2)
    proba = report.predictions[["proba_a", "proba_b", "proba_c"]].to_numpy()
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, rtol=0, atol=4e-16)
