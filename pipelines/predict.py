"""Predict the terrain of every window of the runs in a folder with a trained model.

RUNS_DIR is any folder in the measured-run layout <TERRAIN>/{imu_XX,pro_XX}.csv (the terrain
folder names are ignored). Output: one row per window with run, t_start_s, t_end_s,
predicted and one proba_<CLASS> column per class.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from terrain.io.measured import read_runs_dir
from terrain.serving import load_model, runs_to_model_input
from terrain.tracking import tracked_run

EXPERIMENT = "terrain-predict"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain predict``."""
    parser.add_argument("--model", required=True,
                        help="MLflow model directory or URI (models:/terrain-borealtc/1)")
    parser.add_argument("runs_dir", type=Path, metavar="RUNS_DIR")
    parser.add_argument("--out", type=Path, required=True, help="predictions CSV")


def main(args: argparse.Namespace) -> int:
    """Load the model, align and window the runs, write the predictions."""
    runs = read_runs_dir(args.runs_dir, labelled=False)
    model, meta = load_model(args.model)
    samples, skipped = runs_to_model_input(runs, meta["channels"], float(meta["rate_hz"]))
    with tracked_run(EXPERIMENT, params={"model": str(args.model),
                                         "runs_dir": str(args.runs_dir)}) as run:
        pred = model.predict(samples)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        pred.to_csv(args.out, index=False)
        run.log_metrics({"n_windows": len(pred), "n_runs": len(runs),
                         "n_runs_skipped": len(skipped)})
        run.log_table(pred, "predictions.csv")
    print(f"{len(pred)} windows from {len(runs) - len(skipped)} runs -> {args.out}")
    if skipped:
        print(f"skipped {len(skipped)} run(s) lacking a stream the model needs: {skipped}")
    counts = pred["predicted"].value_counts().to_dict()
    print(f"predicted windows per class: {counts}")
    print(run.describe())
    return 0
