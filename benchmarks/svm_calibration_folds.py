"""SVM probability calibration: folds stratified over windows (shipped) or grouped by run.

The served SVM (:func:`terrain.models.svm.make_svm` with ``probability=True``) fits its
Platt scaling on ``StratifiedKFold(5)`` out-of-fold decision values of the training windows,
so windows of one run sit on both sides of a calibration fold (never a test run). This
probe asks whether calibration folds grouped by run (``StratifiedGroupKFold`` over the
training runs) give probabilities that are better calibrated on held-out runs. Both variants
are the shipped pipeline; the grouped one only has ``svc__cv`` set to grouped splits of each
outer fold's training windows. Outer split: the project's run-grouped protocol
(:func:`terrain.models.cv.iter_splits` ``grouped``, 5 folds) on the main job's windows
(``terrain cv`` defaults: all signals, 2 s). Scored on the held-out windows pooled over the
folds: accuracy and macro-F1 of the argmax, log-loss, and the expected calibration error
(ECE, 10 confidence bins), with the mean confidence beside the accuracy. Printed and logged
to MLflow (experiment ``terrain-benchmark``, run ``svm-calibration-folds``). BorealTC only:
Vulpi has classes of one run, which calibration folds grouped by run cannot put on both
sides of a fold (and which the project's CV cuts into time blocks).

Usage: ``python benchmarks/svm_calibration_folds.py [--seeds 0 1 2]`` (about 15 s on 2
cores).
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import pandas as pd
from sklearn.base import clone
from sklearn.metrics import log_loss
from sklearn.model_selection import StratifiedGroupKFold

from pipelines.arguments import DistinctSeeds, seed_value
from terrain.models.cv import iter_splits
from terrain.models.experiment import ExperimentConfig, feature_extractor, load_windows
from terrain.models.metrics import window_metrics
from terrain.models.svm import SVMConfig, make_svm
from terrain.tracking import require_store, tracked_run


def expected_calibration_error(proba: np.ndarray, correct: np.ndarray, n_bins: int = 10
                               ) -> float:
    """Expected calibration error of the top-class confidence.

    Parameters
    ----------
    proba : ndarray, shape (n_windows, n_classes)
        Class probabilities.
    correct : ndarray of bool, shape (n_windows,)
        Whether the argmax is the true class.
    n_bins : int
        Equal-width confidence bins over (0, 1].

    Returns
    -------
    float
        ``sum_b (n_b / n) |accuracy_b - confidence_b|`` (Guo et al. 2017, "On calibration
        of modern neural networks", eq. 3).
    """
    conf = proba.max(axis=1)
    edges = np.linspace(0.0, 1.0, n_bins + 1)
    ece = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        inside = (conf > lo) & (conf <= hi)
        if inside.any():
            ece += inside.mean() * abs(correct[inside].mean() - conf[inside].mean())
    return float(ece)


def score_seed(features: np.ndarray, labels: np.ndarray, runs: np.ndarray, groups: np.ndarray,
               seed: int) -> list[dict]:
    """Held-out probabilities of both calibration variants over one seed's outer folds.

    Parameters
    ----------
    features : ndarray, shape (n_windows, n_features)
    labels, runs, groups : ndarray, shape (n_windows,)
        Terrain, run id and split unit of each window.
    seed : int
        Seed of the outer and the grouped calibration splits.

    Returns
    -------
    list of dict
        One row per variant: seed, variant, accuracy, macro_f1, log_loss, ece,
        mean_confidence.
    """
    classes = np.unique(labels)
    proba = {v: np.full((len(labels), len(classes)), np.nan) for v in ("windows", "runs")}
    shipped = make_svm(SVMConfig(probability=True), random_state=seed)
    for train, test in iter_splits("grouped", labels, groups, seed):
        for variant, out in proba.items():
            model = clone(shipped)
            if variant == "runs":
                inner = StratifiedGroupKFold(5, shuffle=True, random_state=seed)
                model.set_params(svc__cv=list(inner.split(features[train], labels[train],
                                                          runs[train])))
            model.fit(features[train], labels[train])
            out[test] = model.predict_proba(features[test])
    rows = []
    for variant, p in proba.items():
        pred = classes[p.argmax(axis=1)]
        correct = pred == labels
        scores = window_metrics(labels, pred, classes)
        rows.append({"seed": seed, "variant": variant, "accuracy": scores["accuracy"],
                     "macro_f1": scores["macro_f1"],
                     "log_loss": log_loss(labels, np.clip(p, 1e-6, 1.0), labels=classes),
                     "ece": expected_calibration_error(p, correct),
                     "mean_confidence": p.max(axis=1).mean()})
    return rows


def main() -> int:
    """Score both variants, print the table and log it to MLflow."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds,
                        default=[0, 1, 2])
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    warnings.filterwarnings("ignore", message="y_pred contains classes not in y_true")
    config = ExperimentConfig(dataset="borealtc")
    ws = load_windows(config)
    features = feature_extractor(ws).transform(ws.X)
    scores = pd.DataFrame([row for seed in args.seeds
                           for row in score_seed(features, ws.labels, ws.run_ids, ws.groups,
                                                 seed)])
    table = scores.groupby("variant", sort=False).mean(numeric_only=True).drop(columns="seed")
    pd.set_option("display.width", 160)
    print(f"borealtc: {len(ws.labels)} windows of {config.window_s:g} s, "
          f"{len(np.unique(ws.run_ids))} runs, seeds {args.seeds}")
    print(scores.round(4).to_string(index=False))
    print("mean over seeds:")
    print(table.round(4).to_string())
    if not args.no_mlflow:
        with tracked_run("terrain-benchmark", run_name="svm-calibration-folds",
                         params={"dataset": "borealtc",
                                 "seeds": ",".join(map(str, args.seeds))}) as run:
            run.log_metrics({f"{variant}__{metric}": float(value)
                             for variant, row in table.iterrows()
                             for metric, value in row.items()})
            run.log_table(scores, "svm_calibration_folds.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
