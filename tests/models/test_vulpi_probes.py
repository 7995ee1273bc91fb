"""Helpers of benchmarks/vulpi_probes.py: the scaling control and the current spectra."""

from __future__ import annotations

import runpy
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from terrain.models.svm import SVMConfig

SCRIPT = runpy.run_path(str(Path(__file__).parents[2] / "benchmarks" / "vulpi_probes.py"))


def _blobs(rng, n=60, shift=0.0):
    X = rng.normal(size=(n, 5))
    y = np.where(X[:, 0] + 0.5 * X[:, 1] > shift, "A", "B")
    return X, y


def test_scaler_from_own_statistics_is_the_plain_svm():
    rng = np.random.default_rng(0)
    X, y = _blobs(rng)
    Xt, _ = _blobs(rng, 40)
    config = SimpleNamespace(svm=SVMConfig())
    got = SCRIPT["_scaler_from_all_predict"](config, X, y, Xt, X)
    plain = make_pipeline(StandardScaler(), SVC(C=config.svm.C, gamma="scale",
                                                class_weight="balanced")).fit(X, y)
    assert np.array_equal(got, plain.predict(Xt))


def test_scaler_from_own_statistics_is_the_plain_svm_whatever_the_feature_units():
    # features in large units: the RBF width is set on the standardised features, as
    # gamma="scale" does inside the pipeline, not on the raw ones (1e4 times too narrow)
    rng = np.random.default_rng(2)
    X, y = _blobs(rng)
    Xt, _ = _blobs(rng, 40)
    X, Xt = 100.0 * X + 3.0, 100.0 * Xt + 3.0
    config = SimpleNamespace(svm=SVMConfig())
    got = SCRIPT["_scaler_from_all_predict"](config, X, y, Xt, X)
    plain = make_pipeline(StandardScaler(), SVC(C=config.svm.C, gamma="scale",
                                                class_weight="balanced")).fit(X, y)
    assert np.array_equal(got, plain.predict(Xt))
    assert len(set(got)) == 2


def test_scaler_keeps_the_statistics_it_was_given():
    # pooled statistics in which feature 0, the informative one, spreads 1000 times wider:
    # standardised with them it carries almost no distance, so the decisions change
    rng = np.random.default_rng(1)
    X, y = _blobs(rng, 80)
    Xt, yt = _blobs(rng, 200)
    stats = np.vstack([X, np.c_[rng.normal(scale=1000.0, size=(80, 1)),
                                rng.normal(size=(80, 4))]])
    config = SimpleNamespace(svm=SVMConfig())
    own = SCRIPT["_scaler_from_all_predict"](config, X, y, Xt, X)
    pooled = SCRIPT["_scaler_from_all_predict"](config, X, y, Xt, stats)
    assert (own == yt).mean() > (pooled == yt).mean() + 0.05


def test_current_band_features_stop_at_the_wheel_nyquist_frequency():
    rate = 50.0
    t = np.arange(100) / rate
    # a 6 Hz ripple on cur_l: its power lies in the 5-7.5 Hz band, the last one kept
    X = np.zeros((1, 3, 100))
    X[0, 0] = 5.0 + np.sin(2 * np.pi * 6.0 * t)
    X[0, 1] = 5.0 + 1e-3 * np.sin(2 * np.pi * 1.0 * t)
    ws = type("W", (), {"channels": ("cur_l", "cur_r", "wz"), "X": X,
                        "__len__": lambda self: 1})()
    F = SCRIPT["current_band_features"](ws, rate)
    assert F.shape == (1, 6)                      # 0-2.5, 2.5-5, 5-7.5 Hz for each current
    assert F[0, 2] == F[0, :3].max()              # cur_l: the ripple's band
    assert F[0, 2] > F[0, 5] + 3                  # cur_l's ripple >> cur_r's at 5-7.5 Hz
