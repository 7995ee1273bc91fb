"""Review tests (mdl27): contracts between the models and the modules around them.

Each test crosses a seam with the real producer and the real consumer: the wheel stream rates
the spectrogram CNN's band limits and the window EKF assume against the rates the readers and
the manifest give; the compare grid's post-hoc soft vote against the out-of-fold prediction
of the registry's :class:`SoftVotingEnsemble`; the documented grid table (CSV and Markdown)
against the compare module's summary of the documented per-seed cells.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from features.windows import resolve_signals
from terrain.io.shipped import DATASET_SPECS, read_shipped
from terrain.models.compare import grid_markdown, soft_vote, summary_table
from terrain.models.cv import cross_validate
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.registry import (WHEEL_RATE_HZ, ModelConfig, band_limits_hz, make_model)
from terrain.models.svm import SVMConfig, svm_window_pipeline

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
CHANNELS = ("wx", "wy", "wz", "ax", "ay", "az", "vel_l", "vel_r", "cur_l", "cur_r")


@pytest.fixture(scope="module")
def wheel_rates():
    """Native wheel rate of each shipped dataset as its reader gives it (median of runs)."""
    return {ds: float(np.median([r.rate_hz("wheels") for r in read_shipped(ds)]))
            for ds in ("borealtc", "vulpi")}


@pytest.mark.slow
def test_wheel_rates_of_the_registry_are_those_of_the_readers_and_the_manifest(wheel_rates):
    manifest = json.loads((DATA / "manifest.json").read_text())["datasets"]
    for ds, rate in wheel_rates.items():
        assert WHEEL_RATE_HZ[ds] == pytest.approx(rate, rel=1e-9)
        assert WHEEL_RATE_HZ[ds] == pytest.approx(manifest[ds]["sampling_rates_hz"]["wheels"])
    # every training set is keyed, a pooled one at the lowest rate of its parts
    assert set(WHEEL_RATE_HZ) == set(DATASET_SPECS)
    for name, spec in DATASET_SPECS.items():
        assert WHEEL_RATE_HZ[name] == min(WHEEL_RATE_HZ[p] for p in spec.parts)


@pytest.mark.parametrize("dataset", sorted(DATASET_SPECS))
def test_spectrogram_band_limits_of_every_wheel_signal_are_the_wheel_nyquist(dataset):
    """Every channel of the signal set ``wheels`` comes from the wheel stream: each is limited
    to its Nyquist frequency, the IMU channels are not."""
    channels = resolve_signals(("all",))
    model = make_model(ModelConfig(kind="cnn-spectrogram"), channels,
                       DATASET_SPECS[dataset].rate_hz, dataset)
    limits = dict(zip(channels, model.band_limits_hz))
    wheels = set(resolve_signals(("wheels",)))
    imu = set(resolve_signals(("imu",)))
    assert wheels and imu and wheels | imu == set(channels)
    assert all(limits[c] == WHEEL_RATE_HZ[dataset] / 2 for c in wheels)
    assert all(limits[c] == np.inf for c in imu)
    assert tuple(model.band_limits_hz) == band_limits_hz(channels, dataset)


@pytest.mark.slow
def test_window_ekf_gets_the_readers_wheel_rate(wheel_rates):
    for ds, rate in wheel_rates.items():
        model = make_model(ModelConfig(kind="svm", window_ekf=True), CHANNELS,
                           DATASET_SPECS[ds].rate_hz, ds)
        assert model.wheel_rate_hz == pytest.approx(rate)
        assert model.rate_hz == DATASET_SPECS[ds].rate_hz


#: channels of the soft-vote check (two keep its twelve SVM fits quick)
VOTE_CHANNELS = ("wz", "az")


def _windows(seed, n_runs=9, per_run=6, s=50, rate=25.0):
    rng = np.random.default_rng(seed)
    run = np.repeat(np.arange(n_runs), per_run)
    y = np.array(["ASPHALT", "ICE", "SNOW"])[run % 3]
    t = np.arange(s) / rate
    f = (1.0 + 2.0 * (run % 3))[:, None, None]
    X = rng.normal(size=(len(run), len(VOTE_CHANNELS), s)) + np.sin(2 * np.pi * f * t)
    runs = np.array([f"r{i}" for i in run])
    t0 = np.tile(np.arange(per_run) * s / rate, n_runs)
    return X, y, runs, t0, t0 + s / rate


def test_compare_soft_vote_is_the_ensembles_out_of_fold_prediction(seed=7, w=(3.0, 1.0)):
    """soft_vote's promise: with fixed weights it is exactly the out-of-fold prediction of
    SoftVotingEnsemble (each member trained deterministically on the same fold)."""
    X, y, runs, t0, t1 = _windows(seed)
    rate = 25.0
    members = [(name, lambda s, c=c: svm_window_pipeline(
        VOTE_CHANNELS, rate, SVMConfig(C=c, probability=True), s))
        for name, c in (("a", 1.0), ("b", 10.0))]
    kw = dict(protocol="grouped", seeds=(seed,), n_splits=2)
    alone = [cross_validate(f, X, y, runs, runs, t0, t1, **kw).predictions for _, f in members]
    ens = cross_validate(lambda s: SoftVotingEnsemble([(n, f(s)) for n, f in members],
                                                      weights=w, random_state=s),
                         X, y, runs, runs, t0, t1, **kw).predictions
    classes = sorted(set(y))
    voted = soft_vote(alone, classes, weights=w)
    key = ["seed", "fold", "run", "t_start_s"]
    ens = ens.sort_values(key).reset_index(drop=True)
    voted = voted.sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(ens[key], voted[key])
    cols = [f"proba_{c}" for c in classes]
    np.testing.assert_allclose(ens[cols].to_numpy(), voted[cols].to_numpy(), atol=1e-12)
    np.testing.assert_array_equal(ens["predicted"].to_numpy(), voted["predicted"].to_numpy())


def test_documented_grid_table_is_the_summary_of_its_documented_cells():
    """docs/model_comparison_grid.csv and the tables of docs/model_comparison_grid.md are
    summary_table / grid_markdown (k = 1, 5, 10) of docs/model_comparison_grid_seeds.csv:
    column names, units (s per fold, ms per window) and figures agree."""
    cells = pd.read_csv(ROOT / "docs" / "model_comparison_grid_seeds.csv")
    documented = pd.read_csv(ROOT / "docs" / "model_comparison_grid.csv")
    table = summary_table(cells)
    assert list(table.columns) == list(documented.columns)
    keys = ["protocol", "dataset", "signals", "window_s", "train_hop_s", "history", "model"]
    table = table.sort_values(keys).reset_index(drop=True)
    documented = documented.sort_values(keys).reset_index(drop=True)
    pd.testing.assert_frame_equal(table[keys], documented[keys], check_dtype=False)
    values = [c for c in documented.columns if c not in keys]
    np.testing.assert_allclose(table[values].to_numpy(float),
                               documented[values].to_numpy(float), rtol=1e-9, atol=1e-12)
    text = (ROOT / "docs" / "model_comparison_grid.md").read_text()
    lines = {line for line in text.splitlines() if line.startswith("|")}
    rows = [line for line in grid_markdown(table, (1, 5, 10)).splitlines()
            if line.startswith("| ") and not line.startswith("| signals")]
    assert rows and all(line in lines for line in rows)


def test_svm_on_features_computed_once_is_the_registry_svm_on_raw_windows():
    """Two paths, one answer: terrain cv's SVM (features of every window computed once, then
    make_svm per fold: run_cv) and the registry's svm (svm_window_pipeline per fold: the
    compare grid, terrain train) give the same out-of-fold probabilities and decisions."""
    from features.transformers import WindowFeatures
    from terrain.models.svm import make_svm

    X, y, runs, t0, t1 = _windows(3)
    F = WindowFeatures(channels=VOTE_CHANNELS, rate_hz=25.0).fit(X).transform(X)
    kw = dict(protocol="grouped", seeds=(3,), n_splits=2)
    once = cross_validate(lambda s: make_svm(SVMConfig(probability=True), s), F, y, runs,
                          runs, t0, t1, **kw)
    raw = cross_validate(lambda s: make_model(ModelConfig(kind="svm"), VOTE_CHANNELS, 25.0,
                                              "borealtc", s), X, y, runs, runs, t0, t1, **kw)
    cols = [c for c in once.predictions.columns if c.startswith("proba_")]
    assert len(cols) == 3
    np.testing.assert_allclose(raw.predictions[cols].to_numpy(float),
                               once.predictions[cols].to_numpy(float), atol=1e-12)
    np.testing.assert_array_equal(raw.predictions["predicted"], once.predictions["predicted"])
    pd.testing.assert_frame_equal(raw.pooled, once.pooled)


def test_compare_row_at_history_one_is_the_cv_reports_pooled_score():
    """Two paths, one answer: a compare cell's row at k = 1 (score_rows of the out-of-fold
    probabilities) scores what terrain cv's pooled report scores (the decisions of the
    model), its run_vote_accuracy being cv's run_majority_accuracy."""
    from terrain.models.compare import score_rows

    X, y, runs, t0, t1 = _windows(5)
    report = cross_validate(lambda s: make_model(ModelConfig(kind="svm"), VOTE_CHANNELS, 25.0,
                                                 "vulpi", s),
                            X, y, runs, runs, t0, t1, protocol="grouped", seeds=(5,),
                            n_splits=2)
    row, = score_rows(report.predictions, report.classes, (1,), {})
    pooled = report.pooled.iloc[0]
    for key in ("accuracy", "balanced_accuracy", "macro_f1"):
        assert row[key] == pytest.approx(pooled[key], abs=1e-12)
    assert row["run_vote_accuracy"] == pytest.approx(pooled["run_majority_accuracy"])
    assert row["n_windows"] == len(y)
