"""Review (mdl28): MiniRocket fits in threads of one process (joblib's threading backend).

aeon draws the dilations and channels of its kernels from NumPy's global generator after
seeding it: two fits at once drew from one another's seeded stream, and the caller's stream,
saved and put back by each, was left at a fit's seeded state.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

pytest.importorskip("aeon")

from terrain.models.minirocket import MiniRocketFeatures  # noqa: E402


@pytest.fixture
def slow_aeon(monkeypatch):
    """aeon's fit with a pause between seeding NumPy's generator and drawing from it."""
    from aeon.transformations.collection.convolution_based import _minirocket

    dilations = _minirocket._fit_dilations     # called after the seeding, before the draws
    inside = threading.Event()

    def slow(*args, **kwargs):
        inside.set()
        time.sleep(0.2)
        return dilations(*args, **kwargs)

    monkeypatch.setattr(_minirocket, "_fit_dilations", slow)
    return inside


def _features(model):
    return [np.asarray(p) for p in model.rocket_.parameters]


@pytest.mark.slow
def test_two_fits_at_once_draw_the_kernels_of_their_own_seed(slow_aeon):
    X = np.random.default_rng(0).normal(size=(6, 2, 20))
    expected = [_features(MiniRocketFeatures(n_kernels=84, random_state=s).fit(X))
                for s in (0, 1)]
    np.random.seed(123)
    caller = np.random.get_state()[1].copy()
    slow_aeon.clear()
    models = [MiniRocketFeatures(n_kernels=84, random_state=s) for s in (0, 1)]
    a = threading.Thread(target=models[0].fit, args=(X,))
    a.start()
    assert slow_aeon.wait(10)
    b = threading.Thread(target=models[1].fit, args=(X,))
    b.start()
    a.join(30)
    b.join(30)
    for model, want in zip(models, expected):
        for got, ref in zip(_features(model), want):
            np.testing.assert_array_equal(got, ref)
    np.testing.assert_array_equal(np.random.get_state()[1], caller)
