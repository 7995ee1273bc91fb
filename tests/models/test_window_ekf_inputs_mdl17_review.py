"""Windows of booleans refused by the window-EKF wrapper (review mdl17)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.dummy import DummyClassifier

from terrain.errors import EstimationError
from terrain.models.window_ekf import WindowEKFClassifier

CHANNELS = ("vel_l", "vel_r", "wz", "ax")


def _windows():
    rng = np.random.default_rng(0)
    return rng.normal(0.5, 0.1, size=(6, 4, 40)), np.array(list("ababab"))


def test_boolean_windows_are_refused_in_fit_and_predict():
    # augment cast them to 0.0 / 1.0 before the EKF and the wrapped model, whose own refusal
    # of boolean windows (the CNNs', MiniRocket's) then never saw them: a mask handed over
    # for the signals was filtered and classified as wheel speeds of 0 and 1 m/s
    X, y = _windows()
    model = WindowEKFClassifier(DummyClassifier(), CHANNELS, 20.0)
    with pytest.raises(EstimationError, match="X must hold numbers, got booleans"):
        model.fit(X > 0.5, y)
    model.fit(X, y)
    for method in (model.predict_proba, model.predict, model.augment):
        with pytest.raises(EstimationError, match="X must hold numbers, got booleans"):
            method(X > 0.5)
    assert model.predict_proba(X).shape == (6, 2)
