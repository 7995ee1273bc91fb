"""Predict the terrain of every window of the runs in a folder with a trained model.

RUNS_DIR is any folder in the measured-run layout <TERRAIN>/{imu_XX,pro_XX}.csv, or one
<TERRAIN> folder of it (the terrain folder names are ignored). Output: one row per window with
run, t_start_s, t_end_s, predicted, one proba_<CLASS> column per class and flags ("stuck:
<stream>.<channel>" when the window holds a stuck or dead sensor: do not trust it blindly).
"""

from __future__ import annotations

import argparse

import pandas as pd

from features.windows import WindowConfig, required_streams
from pipelines.arguments import input_folder, input_path, output_file
from terrain.errors import ConfigError, DataFormatError
from terrain.io.jsonfile import whole_file
from terrain.io.measured import read_runs_path
from terrain.io.plausibility import stuck_window_flags
from terrain.io.report import input_report
from terrain.serving.model import imu_rate_note, other_vehicle_note
from terrain.serving.pyfunc import load_model, local_model_dir, runs_to_model_input
from terrain.tracking import store_errors, tracked_run

EXPERIMENT = "terrain-predict"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain predict``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser to which the options are added (modified in place).
    """
    parser.add_argument("--model", type=input_path, required=True,
                        help="MLflow model directory or URI (e.g. models:/terrain-borealtc/latest, "
                             "resolved in the tracking store in force, see README)")
    parser.add_argument("runs_dir", type=input_folder, metavar="RUNS_DIR",
                        help="runs folder <TERRAIN>/{imu_XX,pro_XX}.csv or one terrain folder")
    parser.add_argument("--out", type=output_file, required=True, help="predictions CSV")
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")


def _load(uri: str, progress: bool):
    in_store = local_model_dir(uri) is None  # an unsupported URI stops here, in its own words
    hint = (" (a models:/ or runs:/ URI resolves in the tracking store in force: run where "
            "`terrain train` ran or set MLFLOW_TRACKING_URI to its store)" if in_store else "")
    try:
        return load_model(uri, progress=progress)
    except ConfigError as exc:
        raise ConfigError(f"cannot load model {uri!r}: {exc}") from exc
    except (OSError,) + store_errors() as exc:
        first = str(exc).strip().splitlines()[0][:300] if str(exc).strip() else type(exc).__name__
        raise ConfigError(f"cannot load model {uri!r}: {first}{hint}") from None


def main(args: argparse.Namespace) -> int:
    """Load the model, align and window the runs, write the predictions.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        Exit status, 0 on success.

    Raises
    ------
    ConfigError
        When the model at ``args.model`` cannot be loaded (checked before the runs are
        read).
    DataFormatError
        When no run of ``args.runs_dir`` yields a single window (all skipped or shorter than
        the model's window); names the runs folder.
    """
    progress = not args.no_progress
    model, meta = _load(args.model, progress)
    runs = read_runs_path(args.runs_dir, labelled=False, progress=progress)
    window_s = float(meta["window_s"])
    # the samples one window takes, as the model's windowing counts them (window_s * rate_hz
    # rounded: 0.25 s at 50 Hz is 12 samples, 0.24 s, which a run of 12 fills)
    window_samples = WindowConfig(window_s=window_s, rate_hz=float(meta["rate_hz"])).n_samples
    counts: dict = {"per_run": {}, "skipped_runs": [], "too_short_runs": [],
                    "streams": list(required_streams(meta["channels"]))}
    parts = []
    items = runs
    if progress:
        from tqdm.auto import tqdm
        items = tqdm(runs, desc="predicting runs", unit="run")
    other_vehicle, slower_imu = [], []
    for run in items:
        note = other_vehicle_note(meta, run.vehicle, run.run_id)
        if note:
            other_vehicle.append(note)
        note = imu_rate_note(meta["channels"], float(meta["rate_hz"]), run)
        if note:
            slower_imu.append(note)
        samples, skipped = runs_to_model_input([run], meta["channels"], float(meta["rate_hz"]))
        if skipped:
            counts["skipped_runs"].append(run.run_id)
            continue
        pred = model.predict(samples)
        pred["flags"] = stuck_window_flags(run.meta.get("stuck", {}), pred["t_start_s"],
                                           pred["t_end_s"])
        counts["per_run"][run.run_id] = {"windows": len(pred), "dropped_unsteady": 0,
                                         "dropped_gap": int(pred.attrs.get("dropped_windows", 0)),
                                         "empty_gap": int(pred.attrs.get("empty_windows", 0)),
                                         "window_tail_s": float(pred.attrs.get("window_tail_s",
                                                                               0.0)),
                                         "between_windows_s": float(
                                             pred.attrs.get("between_windows_s", 0.0))}
        if len(samples) < window_samples:
            counts["too_short_runs"].append(run.run_id)
        parts.append(pred)
    flagged = {r: int((p["flags"] != "").sum()) for r, p in
               zip(counts["per_run"], parts)}
    inputs = input_report(runs, counts, window_s, flagged)
    print(inputs.text())
    for note in other_vehicle + slower_imu:
        print(note)
    if not parts or not sum(len(p) for p in parts):
        raise DataFormatError(f"no window to predict in {len(runs)} run(s) (see above; a "
                              f"window is {window_s:g} s)", args.runs_dir)
    pred = pd.concat(parts, ignore_index=True)
    # as the input report counts them: a run too short for one window gave none
    used = sum(1 for r in counts["per_run"] if r not in counts["too_short_runs"])
    with tracked_run(EXPERIMENT, params={"model": str(args.model),
                                         "runs_dir": str(args.runs_dir)}) as run:
        with whole_file(args.out) as tmp:  # a failure half-way leaves no half file
            pred.to_csv(tmp, index=False)
        run.log_metrics({"n_windows": len(pred), "n_runs": len(runs), "n_runs_used": used,
                         "n_runs_skipped": len(counts["skipped_runs"]),
                         "n_windows_flagged": int((pred["flags"] != "").sum()),
                         "n_runs_other_vehicle": len(other_vehicle),
                         "n_runs_slower_imu": len(slower_imu),
                         **inputs.metrics()})
        run.log_table(pred, "predictions.csv")
        run.log_table(inputs.table, "input_report.csv")
    print(f"{len(pred)} windows from {used} of {len(runs)} runs -> {args.out}")
    counts_by_class = pred["predicted"].value_counts().to_dict()
    print(f"predicted windows per class: {counts_by_class}")
    print(run.describe())
    return 0
