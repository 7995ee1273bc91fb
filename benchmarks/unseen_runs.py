"""Does the ``terrain train`` default model classify unseen runs at least as well as the SVM?

Every run of ``/work/shared/data`` is shipped (``data/manifest.json`` lists all 70), so no
truly unseen run exists; the honest check is leave-runs-out through the training code path
itself. The runs of a dataset are split into 5 run-grouped folds
(``StratifiedGroupKFold(5, shuffle=True, random_state=seed)`` over the windows, grouped by
run); for each fold, :func:`terrain.models.experiment.fit_pipeline` (what ``terrain train``
calls) fits the default model (:data:`pipelines.train.DEFAULT_MODELS`, with the default
signals :data:`pipelines.train.DEFAULT_SIGNALS` and training-window hop
:data:`pipelines.train.DEFAULT_TRAIN_HOP_S`) and the SVM as it was
trained before that hop existed (non-overlapping windows) on the *same* training runs, and
both fitted inference pipelines classify every window of the held-out runs. A class with a single
run (Vulpi DIRT_ROAD) always stays in training and is never tested (its run cannot be unseen).
Reported: window accuracy and macro-F1 over all held-out windows, run-majority accuracy, and the
per-run paired comparison (runs where the default model is better / equal / worse than the SVM by
window accuracy). Printed and logged to MLflow (experiment ``terrain-train``, run
``unseen-runs-<dataset>``).

Run: ``python benchmarks/unseen_runs.py --dataset borealtc [--seed 0] --out DIR``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from sklearn.model_selection import StratifiedGroupKFold

from features.windows import resolve_signals
from pipelines.arguments import output_dir, positive_integer, seed_value
from pipelines.train import DEFAULT_MODELS, DEFAULT_SIGNALS, DEFAULT_TRAIN_HOP_S
from terrain.io.shipped import DATASET_SPECS, load_dataset
from terrain.models.experiment import ExperimentConfig, fit_pipeline, load_windows
from terrain.models.metrics import run_majority_accuracy, window_metrics
from terrain.tracking import require_store, tracked_run


def main() -> int:
    """Leave-runs-out comparison of the default model and the SVM; print and log it."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", choices=list(DATASET_SPECS), default="borealtc")
    parser.add_argument("--seed", type=seed_value, default=0)
    parser.add_argument("--threads", type=positive_integer, default=1,
                        help="torch threads per CNN fit")
    parser.add_argument("--out", type=output_dir, required=True)
    args = parser.parse_args()
    require_store()   # a store it cannot use stops it now, not after the work
    default = DEFAULT_MODELS[args.dataset]
    runs = load_dataset(args.dataset)
    ws = load_windows(ExperimentConfig(dataset=args.dataset), runs=runs)
    labels = ws.labels.astype(str)
    runs_of = pd.Series(ws.run_ids).groupby(labels).nunique()
    single = set(runs_of[runs_of == 1].index)
    testable = ~np.isin(labels, list(single))
    folds = StratifiedGroupKFold(5, shuffle=True, random_state=args.seed).split(
        ws.X[testable], labels[testable], ws.run_ids[testable])
    models = [default] + (["svm"] if default != "svm" else [])
    frames, t0 = [], time.perf_counter()
    for fold, (_, te) in enumerate(folds):
        test_ids = set(ws.run_ids[testable][te])
        train_runs = [r for r in runs if r.run_id not in test_ids]
        test_runs = [r for r in runs if r.run_id in test_ids]
        test_ws = load_windows(ExperimentConfig(dataset=args.dataset), runs=test_runs)
        frame = pd.DataFrame({"fold": fold, "run": test_ws.run_ids,
                              "true": test_ws.labels.astype(str)})
        for kind in models:
            # the default with its signals and training-window hop; the SVM reference on all
            # signals, non-overlapping (the same windows: a signal set only selects channels)
            signals = DEFAULT_SIGNALS.get(args.dataset, ("all",)) if kind == default \
                else ("all",)
            config = ExperimentConfig(dataset=args.dataset, model=kind, seeds=(args.seed,),
                                      n_threads=args.threads, signals=signals,
                                      train_hop_s=(DEFAULT_TRAIN_HOP_S.get(args.dataset)
                                                   if kind == default else None))
            pipe, _, _ = fit_pipeline(config, runs=train_runs)
            keep = [list(test_ws.channels).index(c) for c in resolve_signals(signals)]
            frame[kind] = pipe.predict(test_ws.X[:, keep])
        frames.append(frame)
        print(f"  fold {fold}: {len(test_ids)} held-out runs, "
              + ", ".join(f"{k} {(frame[k] == frame['true']).mean():.3f}" for k in models),
              flush=True)
    wall_s = time.perf_counter() - t0
    pred = pd.concat(frames, ignore_index=True)
    classes = sorted(pred["true"].unique())
    metrics = {}
    for kind in models:
        m = window_metrics(pred["true"], pred[kind], classes)
        metrics.update({f"{kind}_accuracy": m["accuracy"], f"{kind}_macro_f1": m["macro_f1"],
                        f"{kind}_run_vote_accuracy": run_majority_accuracy(
                            pred["true"], pred[kind], pred["run"])})
    per_run = pred.groupby("run").apply(
        lambda g: pd.Series({k: float((g[k] == g["true"]).mean()) for k in models}),
        include_groups=False)
    if default != "svm":
        diff = per_run[default] - per_run["svm"]
        metrics.update({"runs_default_better": int((diff > 1e-9).sum()),
                        "runs_equal": int((diff.abs() <= 1e-9).sum()),
                        "runs_default_worse": int((diff < -1e-9).sum())})
    metrics["wall_s"] = wall_s
    args.out.mkdir(parents=True, exist_ok=True)
    pred.to_csv(args.out / f"unseen_runs_{args.dataset}.csv", index=False)
    print(f"{args.dataset}: default model {default!r} vs svm on the same training runs, "
          f"{pred['run'].nunique()} held-out runs, {len(pred)} windows "
          f"(never tested: single-run classes {sorted(single)})")
    for k, v in metrics.items():
        print(f"  {k:28s} {v:.4f}" if isinstance(v, float) else f"  {k:28s} {v}")
    with tracked_run("terrain-train", run_name=f"unseen-runs-{args.dataset}",
                     params={"dataset": args.dataset, "default_model": default,
                             "default_signals": "+".join(
                                 DEFAULT_SIGNALS.get(args.dataset, ("all",))),
                             "default_train_hop_s": DEFAULT_TRAIN_HOP_S.get(args.dataset),
                             "seed": args.seed, "protocol": "leave-runs-out (5 run folds)"}
                     ) as run:
        run.log_metrics({k: float(v) for k, v in metrics.items()})
        run.log_artifact(args.out / f"unseen_runs_{args.dataset}.csv")
    print(run.describe())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
