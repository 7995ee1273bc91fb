"""Where does a cross-validated terrain classifier fail: straight driving or turning?

Reads the out-of-fold predictions of a ``terrain cv`` run (its MLflow artifact
``predictions.csv``: ``run``, ``t_start_s``, ``t_end_s``, ``true``, ``predicted``, one row
per window and ``seed``), computes each window's mean absolute yaw rate from the run's IMU
(``wz``, rad/s) over the window, and prints the accuracy per true class (pooled over the
seeds) for straight windows (mean ``|wz|`` at most ``--turning-rad-s``) and turning ones
(how many: each window counted once), then the confusion of the straight windows. A terrain
that differs from another only in its friction or its soil strength shows it when the robot
demands traction or turns; driving straight at constant speed it may not.

Run: ``python benchmarks/errors_by_manoeuvre.py RUN_ID [--dataset borealtc]
[--turning-rad-s 0.1] [--out FILE.csv]``. A run id without ``predictions.csv``, or
predictions of runs that ``--dataset`` does not hold (a cv run of another dataset), is a
usage error.
"""

from __future__ import annotations

import argparse

import mlflow
import numpy as np
import pandas as pd
from mlflow.exceptions import MlflowException

from pipelines.arguments import non_negative_number, output_file
from terrain.io.shipped import DATASET_SPECS, load_dataset
from terrain.tracking import activate_store


def mean_abs_yaw_rate(predictions: pd.DataFrame, runs) -> np.ndarray:
    """Mean ``|wz|`` of every window, rad/s (NaN for a run without IMU).

    Parameters
    ----------
    predictions : pandas.DataFrame
        ``run``, ``t_start_s``, ``t_end_s`` (s) per window.
    runs : sequence of Run
        The dataset's runs.

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)``.
    """
    imu = {r.run_id: r.streams["imu"] for r in runs if "imu" in r.streams}
    out = np.full(len(predictions), np.nan)
    for run_id, rows in predictions.groupby("run").groups.items():
        if run_id not in imu:
            continue
        t, wz = imu[run_id]["t_s"].to_numpy(), np.abs(imu[run_id]["wz"].to_numpy())
        cum = np.r_[0.0, np.cumsum(wz)]
        sub = predictions.loc[rows]
        a = np.searchsorted(t, sub["t_start_s"].to_numpy(), side="left")
        b = np.searchsorted(t, sub["t_end_s"].to_numpy(), side="left")
        with np.errstate(invalid="ignore", divide="ignore"):
            out[predictions.index.get_indexer(rows)] = (cum[b] - cum[a]) / (b - a)
    return out


def main() -> int:
    """Print accuracy by class and manoeuvre, and the straight windows' confusion."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("run_id", help="MLflow run of terrain cv (experiment terrain-cv)")
    parser.add_argument("--dataset", choices=list(DATASET_SPECS), default="borealtc")
    parser.add_argument("--turning-rad-s", type=non_negative_number, default=0.1)
    parser.add_argument("--out", type=output_file, default=None, help="write the per-window table")
    args = parser.parse_args()
    activate_store()
    try:
        path = mlflow.artifacts.download_artifacts(run_id=args.run_id,
                                                   artifact_path="predictions.csv")
    except (MlflowException, OSError) as exc:
        parser.error(f"argument run_id: no predictions.csv of MLflow run {args.run_id!r}: "
                     f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}")
    pred = pd.read_csv(path).reset_index(drop=True)
    runs = load_dataset(args.dataset)
    foreign = sorted(set(pred["run"]) - {r.run_id for r in runs})
    if foreign:     # mean_abs_yaw_rate would count their windows as runs without IMU
        parser.error(f"argument --dataset: {args.dataset} does not hold {len(foreign)} of "
                     f"the runs in MLflow run {args.run_id}'s predictions ("
                     f"{', '.join(foreign[:5])}{', ...' if len(foreign) > 5 else ''}); "
                     "is it a cv run of another dataset?")
    pred["abs_wz_rad_s"] = mean_abs_yaw_rate(pred, runs)
    pred["correct"] = pred["true"] == pred["predicted"]
    known = pred["abs_wz_rad_s"].notna()
    pred["manoeuvre"] = np.where(pred["abs_wz_rad_s"] > args.turning_rad_s, "turning",
                                 "straight")
    # terrain cv scores every window once per seed (a row each): accuracies pool the rows,
    # counts and shares count each window once
    window = pred.groupby(["run", "t_start_s", "t_end_s"], sort=False).ngroup()
    n_seeds = pred["seed"].nunique() if "seed" in pred else 1
    table = (pred[known].assign(window=window)
             .groupby(["true", "manoeuvre"])
             .agg(mean=("correct", "mean"), size=("window", "nunique"))
             .unstack("manoeuvre"))
    print(f"run {args.run_id}: {window.nunique()} out-of-fold windows "
          f"({window[~known].nunique()} without IMU)"
          + (f", each scored by {n_seeds} seeds" if n_seeds > 1 else "")
          + f", turning = mean |wz| > {args.turning_rad_s:g} rad/s")
    print(table.round(3).to_string())
    once = ~window.duplicated()
    share = (pred.loc[known & once, "manoeuvre"] == "straight").mean()
    # NaN for a manoeuvre with no window (e.g. a threshold above every window's |wz|)
    overall = pred[known].groupby("manoeuvre")["correct"].mean().reindex(
        ["straight", "turning"])
    print(f"straight windows {share:.3f} of all; accuracy straight {overall['straight']:.3f}, "
          f"turning {overall['turning']:.3f}")
    straight = pred[known & (pred["manoeuvre"] == "straight")]
    print("straight windows, true (rows) -> predicted (share of the row):")
    print(pd.crosstab(straight["true"], straight["predicted"], normalize="index").round(3)
          .to_string())
    if args.out is not None:
        pred.to_csv(args.out, index=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
