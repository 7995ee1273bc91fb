"""A second fit of a model is a fresh fit: nothing of the first is left, whatever settings
changed in between; and a refused fit leaves the model as it was."""

from __future__ import annotations

import pickle

import numpy as np
import pandas as pd
import pytest
from sklearn.base import clone

from terrain.errors import ConfigError
from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.slip.learned import SlipRegressor

pytestmark = pytest.mark.filterwarnings("ignore::terrain.errors.DataWarning")

RATE_HZ = 50.0
CNN = dict(max_epochs=2, width=4, batch_size=16, device="cpu", n_threads=1)


def _windows(classes=("A", "B", "C"), runs: int = 3, per_run: int = 4, seed: int = 0):
    rng = np.random.default_rng(seed)
    X, y, groups = [], [], []
    for k, c in enumerate(classes):
        for r in range(runs):
            for _ in range(per_run):
                X.append(rng.normal(0.5 * k, 1.0, (2, 32)))
                y.append(c)
                groups.append(f"{c}{r}")
    return np.asarray(X, dtype=np.float32), np.asarray(y), np.asarray(groups)


def _state(model) -> dict:
    """Fitted attributes (``name_``), comparably: arrays and plain values as they are,
    fitted objects (networks, trees, members) by their type."""
    out = {}
    for key, value in vars(model).items():
        if not key.endswith("_") or key.startswith("_"):
            continue
        if isinstance(value, np.ndarray):
            value = ("array", value.dtype.str, value.shape, value.tolist())
        elif isinstance(value, (list, tuple)) and value and not isinstance(
                value[0], (int, float, str, np.generic, np.ndarray)):
            value = [type(v).__name__ for v in value]
        elif not isinstance(value, (int, float, str, dict, tuple, list, type(None))):
            value = type(value).__name__
        out[key] = value
    return out


def _assert_same_state(a, b):
    sa, sb = _state(a), _state(b)
    assert sorted(sa) == sorted(sb)
    for key in sa:
        assert repr(sa[key]) == repr(sb[key]), key


@pytest.mark.parametrize("make, first, second", [
    # early stopping on held-out runs, then none: no validation runs left over
    (lambda: RawCNNClassifier(**CNN), dict(early_stopping=True, validation_splits=3),
     dict(early_stopping=False)),
    # band limits (a mask), then none: no mask left over
    (lambda: SpectrogramCNNClassifier(rate_hz=RATE_HZ, segment_s=0.2, hop_s=0.1, **CNN),
     dict(band_limits_hz=(np.inf, 5.0)), dict(band_limits_hz=None)),
])
def test_a_cnn_refit_under_other_settings_is_a_fresh_fit(make, first, second):
    X, y, groups = _windows()
    model = make().set_params(**first).fit(X, y, groups=groups)
    model.set_params(**second).fit(X, y)
    fresh = make().set_params(**second).fit(X, y)
    _assert_same_state(model, fresh)
    np.testing.assert_array_equal(model.predict_proba(X), fresh.predict_proba(X))


def _members():
    return [("a", RawCNNClassifier(**CNN)), ("b", RawCNNClassifier(**CNN, random_state=1))]


def test_an_ensemble_refit_without_runs_keeps_no_chosen_weights():
    X, y, groups = _windows()
    model = SoftVotingEnsemble(_members(), inner_splits=3).fit(X, y, groups=groups)
    assert model.weight_scores_ and model.validation_groups_.size
    model.fit(X, y)
    fresh = SoftVotingEnsemble(_members(), inner_splits=3).fit(X, y)
    _assert_same_state(model, fresh)
    assert model.weight_scores_ == {} and model.validation_groups_.size == 0


def test_a_slip_model_refit_keeps_nothing_of_a_calibrated_named_fit():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(240, 3))
    y = np.column_stack([0.1 * X[:, 0], 0.1 * X[:, 1], 1 + 0.1 * X[:, 2], 0.01 * X[:, 0]])
    groups = np.repeat(np.arange(12), 20)
    settings = dict(max_iter=5, min_samples_leaf=5)
    model = SlipRegressor(**settings).fit(pd.DataFrame(X, columns=["a", "b", "c"]), y, groups)
    assert model.calibration_ and hasattr(model, "feature_names_in_")
    model.fit(X, y)
    fresh = SlipRegressor(**settings).fit(X, y)
    _assert_same_state(model, fresh)
    assert np.isnan(model.predict_std(X)).all()


def _refused(kind: str):
    """A model fitted on A/B/C and the fit that refuses other windows labelled P/Q/R."""
    X, y, groups = _windows()
    X2, y2, g2 = _windows(classes=("P", "Q", "R"), seed=5)
    X2 = X2 * 10.0
    if kind == "cnn":
        model = RawCNNClassifier(**CNN).fit(X, y)
        return model, X, lambda: model.fit(X2, y2, sample_weight=-np.ones(len(y2)))
    if kind == "spectrogram":
        model = SpectrogramCNNClassifier(rate_hz=RATE_HZ, segment_s=0.2, hop_s=0.1,
                                         **CNN).fit(X, y)
        return model, X, lambda: model.set_params(band_limits_hz=(1.0,)).fit(X2, y2)
    model = SoftVotingEnsemble(_members()).fit(X, y, groups=groups)
    return model, X, lambda: model.set_params(weights=(1.0, -1.0)).fit(X2, y2)


@pytest.mark.parametrize("kind", ["cnn", "spectrogram", "ensemble"])
def test_a_refused_refit_leaves_the_previous_fit_whole(kind):
    # a refit refused after it had set the new classes and scaling left them beside the
    # previous network: predictions of the old network under the new labels P/Q/R
    model, X, refit = _refused(kind)
    before = pickle.loads(pickle.dumps(model))
    with pytest.raises((ValueError, ConfigError)):
        refit()
    _assert_same_state(model, before)
    assert list(model.classes_) == ["A", "B", "C"]
    np.testing.assert_array_equal(model.predict_proba(X), before.predict_proba(X))


def test_a_refused_first_fit_leaves_the_model_unfitted():
    from sklearn.exceptions import NotFittedError

    X, y, _ = _windows()
    model = RawCNNClassifier(**CNN)
    with pytest.raises(ValueError):
        model.fit(X, y, sample_weight=-np.ones(len(y)))
    assert _state(model) == {}
    with pytest.raises(NotFittedError):
        model.predict(X)
    assert repr(clone(model).get_params()) == repr(model.get_params())
