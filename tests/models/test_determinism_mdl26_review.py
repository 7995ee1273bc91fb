"""Determinism of the models' fits and probabilities (review mdl26): the same seed gives
bit-identical results however the fits are scheduled (threads, processes, pickles)."""

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("skorch")

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
