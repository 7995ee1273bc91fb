"""The CNNs on a GPU and on the CPU: same protocol, same code, accuracy and cost side by side.

Issue 13 asks for CNNs that train deterministically on the CPU and use a GPU where one is
present, with nothing requiring one. This benchmark cross-validates each CNN once per
device under the headline protocol (run-grouped ``StratifiedGroupKFold(5)``, the windows
and folds of a ``terrain compare`` cell: all signals, non-overlapping 2 s windows) through
``terrain.models.cv.cross_validate``, with the estimator's ``device`` set to each of
``--devices``. Per model and device it prints the pooled out-of-fold accuracy and macro-F1
(mean and spread over the split seeds), the train time per fold and the time of one
window's ``predict_proba`` (batch of 1, ``time_inference`` windows per fold).

GPU training is not bit-reproducible (cuDNN's kernels sum in other orders), so its
figures are expected to differ from the CPU's by about the spread between seeds, not to
equal them.

Run: ``python benchmarks/cnn_device.py [--models cnn-spectrogram cnn] [--devices cuda cpu]
[--seeds 0 1 2] [--threads 2] [--out FILE.csv] [--no-mlflow]`` (the CUDA rows need a GPU;
on the 16-core GPU machine of this project's sessions both devices take ~6 min).
"""

from __future__ import annotations

import argparse
import time

import pandas as pd

from pipelines.arguments import (DistinctSeeds, DistinctValues, output_file, positive_integer,
                                 seed_value)
from terrain.models.compare import Cell, CompareConfig, cell_windows
from terrain.models.cv import cross_validate
from terrain.models.registry import CNN_MODELS, ModelConfig, make_model


def device_rows(kind: str, device: str, seeds: list[int], threads: int,
                dataset: str = "borealtc", time_windows: int = 50) -> list[dict]:
    """Cross-validate one CNN on one device; one row per split seed.

    Parameters
    ----------
    kind : str
        ``cnn`` or ``cnn-spectrogram`` (:data:`terrain.models.registry.MODELS`).
    device : str
        torch device of the estimator (``cpu``, ``cuda``, ``auto``).
    seeds : list of int
        Split and model seeds.
    threads : int
        torch CPU threads during ``fit``.
    dataset : str
        Shipped dataset.
    time_windows : int
        Test windows timed one by one per fold.

    Returns
    -------
    list of dict
        ``model, device, seed, accuracy, macro_f1, fit_s_per_fold, infer_ms_per_window``
        (s and ms of wall time).
    """
    compare = CompareConfig()
    rows = []
    for seed in seeds:
        ws, labels, groups = cell_windows(Cell(kind, "all", 2.0, dataset, seed),
                                          compare.single_run_blocks)[:3]

        def make(s: int):
            model = make_model(ModelConfig(kind, n_threads=threads), ws.channels, ws.rate_hz,
                               dataset, s)
            return model.set_params(device=device)

        report = cross_validate(make, ws.X, labels, groups, ws.run_ids, ws.t_start_s,
                                ws.t_end_s, "grouped", (seed,), compare.n_splits,
                                time_inference=time_windows)
        pooled = report.pooled.iloc[0]
        rows.append({"model": kind, "device": device, "seed": seed,
                     "accuracy": float(pooled["accuracy"]),
                     "macro_f1": float(pooled["macro_f1"]),
                     "fit_s_per_fold": float(report.folds["fit_s"].mean()),
                     "infer_ms_per_window": float(report.folds["infer_ms_per_window"]
                                                  .median())})
        print(f"{kind} on {device}, seed {seed}: accuracy {rows[-1]['accuracy']:.4f}, "
              f"fit {rows[-1]['fit_s_per_fold']:.1f} s per fold, "
              f"{rows[-1]['infer_ms_per_window']:.3f} ms per window", flush=True)
    return rows


def _device(text: str) -> str:
    """``--devices``: ``auto`` or a device string torch reads (``cpu``, ``cuda``,
    ``cuda:1``)."""
    import torch

    if text != "auto":
        try:
            torch.device(text)
        except RuntimeError as exc:
            raise argparse.ArgumentTypeError(f"not a torch device: {text!r} ({exc})") from None
    return text


def main() -> int:
    """Cross-validate every model on every device, print and log the table."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", action=DistinctValues, choices=CNN_MODELS,
                        default=["cnn-spectrogram", "cnn"])
    parser.add_argument("--devices", nargs="+", action=DistinctValues,
                        type=_device, default=["cuda", "cpu"])
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds,
                        default=[0, 1, 2])
    parser.add_argument("--threads", type=positive_integer, default=2,
                        help="torch CPU threads per fit")
    parser.add_argument("--out", type=output_file, default=None, help="write the table as CSV here")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        from terrain.tracking import require_store
        require_store()
    t0 = time.perf_counter()
    rows = [row for kind in args.models for device in args.devices
            for row in device_rows(kind, device, args.seeds, args.threads)]
    seeds = pd.DataFrame(rows)
    table = (seeds.groupby(["model", "device"], sort=False)
             .agg(accuracy_mean=("accuracy", "mean"), accuracy_std=("accuracy", "std"),
                  macro_f1_mean=("macro_f1", "mean"), macro_f1_std=("macro_f1", "std"),
                  fit_s_per_fold=("fit_s_per_fold", "mean"),
                  infer_ms_per_window=("infer_ms_per_window", "median"))
             .round(4).reset_index())
    pd.set_option("display.width", 160)
    print(f"borealtc, run-grouped StratifiedGroupKFold(5), seeds {args.seeds}, "
          f"{args.threads} CPU threads per fit ({time.perf_counter() - t0:.0f} s)")
    print(table.to_string(index=False))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(args.out, index=False)
    if not args.no_mlflow:
        from terrain.tracking import tracked_run
        params = {"models": ",".join(args.models), "devices": ",".join(args.devices),
                  "seeds": ",".join(map(str, args.seeds)), "threads": args.threads}
        with tracked_run("terrain-benchmark", run_name="cnn-device", params=params) as run:
            run.log_metrics({f"{r.model}__{r.device}__{m}": getattr(r, m)
                             for r in table.itertuples()
                             for m in ("accuracy_mean", "fit_s_per_fold",
                                       "infer_ms_per_window")})
            run.log_table(table, "cnn_device.csv")
            run.log_table(seeds, "cnn_device_seeds.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
