"""Tuned vs equal soft-voting weights of the ensemble under the run-grouped headline protocol.

For every seed and outer ``StratifiedGroupKFold(5)`` fold (grouped by run, single-run classes
cut into time blocks exactly as ``terrain compare``), one
``SoftVotingEnsemble(weights=None)`` (``ModelConfig(kind="ensemble", tune_weights=True)``) is
fitted on the training runs: it chooses its weights on whole runs held out of the training
fold (inner ``StratifiedGroupKFold(4)``, log loss on a 0.25 simplex grid), then refits the
members on the whole training fold. The members are deterministic, so the equal-weight
ensemble of the same fold is the plain mean of those refitted members' probabilities: both
variants are scored on the same test windows from one fit. Nothing outside the training fold
chooses a weight. Prints and logs (MLflow experiment ``terrain-compare``, run
``ensemble-weights``) accuracy, balanced accuracy, macro-F1 and run-vote accuracy at history
k, mean and std over seeds, plus the chosen weights per fold.

Run: ``python benchmarks/ensemble_weights.py --dataset borealtc --seeds 0 1 2 --out DIR``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from pipelines.arguments import (DistinctSeeds, DistinctValues, output_dir, positive_integer,
                                 seed_value)
from terrain.io.shipped import DATASET_SPECS
from terrain.models.compare import Cell, CompareConfig, cell_windows, score_rows
from terrain.models.cv import fit_with_groups, iter_splits
from terrain.models.ensemble import aligned_proba
from terrain.models.registry import ModelConfig, make_model
from terrain.tracking import require_store, tracked_run


def _fold(ws, labels, groups, classes, dataset, seed, fold, train, test, threads):
    """Fit the tuned ensemble on one training fold; test-window frames of both variants."""
    model = make_model(ModelConfig(kind="ensemble", tune_weights=True, n_threads=threads),
                       ws.channels, ws.rate_hz, dataset, seed)
    t0 = time.perf_counter()
    fit_with_groups(model, ws.X[train], labels[train], groups[train])
    fit_s = time.perf_counter() - t0
    probas = [aligned_proba(est, ws.X[test], np.asarray(classes)) for est in model.estimators_]
    frames = {}
    for name, w in (("equal", np.full(len(probas), 1.0 / len(probas))),
                    ("tuned", model.weights_)):
        p = sum(wi * pi for wi, pi in zip(w, probas))
        frame = pd.DataFrame({"seed": seed, "fold": fold, "run": ws.run_ids[test],
                              "group": groups[test], "t_start_s": ws.t_start_s[test],
                              "true": labels[test],
                              "predicted": np.asarray(classes)[p.argmax(axis=1)]})
        for j, c in enumerate(classes):
            frame[f"proba_{c}"] = p[:, j]
        frames[name] = frame
    weights = {f"weight_{n}": float(w) for (n, _), w in zip(model.estimators, model.weights_)}
    return frames, {"seed": seed, "fold": fold, "fit_s": fit_s, **weights}


def main() -> int:
    """Cross-validate both weightings, print and log the table."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", choices=list(DATASET_SPECS), default="borealtc")
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds,
                        default=[0, 1, 2])
    parser.add_argument("--history", type=positive_integer, nargs="+", action=DistinctValues,
                        default=[1, 10])
    parser.add_argument("--threads", type=positive_integer, default=1,
                        help="torch threads per CNN fit")
    parser.add_argument("--n-jobs", type=positive_integer, default=1,
                        help="joblib workers over folds")
    parser.add_argument("--out", type=output_dir, required=True)
    args = parser.parse_args()
    require_store()   # a store it cannot use stops it now, not after the work
    config = CompareConfig(datasets=(args.dataset,), signals=("all",), windows_s=(2.0,))
    ws, labels, groups = cell_windows(Cell("ensemble", "all", 2.0, args.dataset, 0),
                                      config.single_run_blocks)[:3]
    classes = sorted(np.unique(labels))
    tasks = [(seed, fold, tr, te) for seed in args.seeds
             for fold, (tr, te) in enumerate(iter_splits("grouped", labels, groups, seed))]
    t0 = time.perf_counter()
    results = Parallel(n_jobs=args.n_jobs)(
        delayed(_fold)(ws, labels, groups, classes, args.dataset, seed, fold, tr, te,
                       args.threads) for seed, fold, tr, te in tasks)
    wall_s = time.perf_counter() - t0
    folds = pd.DataFrame([info for _, info in results])
    rows = []
    for variant in ("equal", "tuned"):
        pred = pd.concat([frames[variant] for frames, _ in results], ignore_index=True)
        for seed, g in pred.groupby("seed"):
            rows += score_rows(g, classes, args.history, {"variant": variant, "seed": seed})
    rows = pd.DataFrame(rows)
    metrics = ["accuracy", "balanced_accuracy", "macro_f1", "run_vote_accuracy"]
    table = rows.groupby(["history", "variant"])[metrics].agg(["mean", "std"])
    args.out.mkdir(parents=True, exist_ok=True)
    rows.to_csv(args.out / "ensemble_weights_rows.csv", index=False)
    folds.to_csv(args.out / "ensemble_weights_folds.csv", index=False)
    print(table.round(4).to_string())
    print(folds.round(3).to_string(index=False))
    print(f"wall {wall_s:.0f} s for {len(tasks)} folds")
    with tracked_run("terrain-compare", run_name="ensemble-weights",
                     params={"dataset": args.dataset, "seeds": ",".join(map(str, args.seeds)),
                             "protocol": "grouped", "signals": "all", "window_s": 2.0}) as run:
        run.log_metrics({f"{v}_{m}_k{k}_{s}": float(table.loc[(k, v), (m, s)])
                         for k, v in table.index for m in metrics for s in ("mean", "std")})
        run.log_metrics({"wall_s": wall_s})
        run.log_artifact(args.out / "ensemble_weights_rows.csv")
        run.log_artifact(args.out / "ensemble_weights_folds.csv")
    print(run.describe())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
