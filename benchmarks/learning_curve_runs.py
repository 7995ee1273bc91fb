"""Is the terrain classifier limited by the number of labelled runs? Accuracy on unseen runs
against the share of runs it is trained on.

Run-grouped ``StratifiedGroupKFold(n)`` for n in ``--splits`` (default 2, 3, 5, 10: each
model trained on 1/2, 2/3, 4/5 and 9/10 of the runs) on the windows of a ``terrain compare``
cell (``terrain.models.compare.cell_windows``; all signals, non-overlapping 2 s windows).
Every window is scored once per split seed whatever n is, so the rows differ only in how
many runs each fold's model learns from. Members (``--models``, default ``svm cnn
cnn-spectrogram``) are cross-validated on the same folds (``terrain.models.cv.
cross_validate``) and their equal-weight soft votes added (``ensemble``: SVM + spectrogram
CNN, ``ensemble3``: all three), scored at a decision history of 1 and 10 windows
(``terrain.models.compare.score_rows``), mean and spread over ``--seeds``. n = 5 is the
headline protocol of the README tables and reproduces them.

Run: ``python benchmarks/learning_curve_runs.py [--dataset borealtc] [--splits 2 3 5 10]
[--seeds 0 1 2] [--models svm cnn cnn-spectrogram] [--out CSV] [--figure PNG]
[--no-mlflow]`` (BorealTC, defaults: ~15 min on the 2-core machine).
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from pipelines.arguments import (DistinctSeeds, DistinctValues, integer_in, output_file,
                                 positive_integer, seed_value)
from terrain.io.shipped import DATASET_SPECS
from terrain.models.compare import Cell, CompareConfig, cell_windows, score_rows, soft_vote
from terrain.models.cv import cross_validate
from terrain.models.registry import (ENSEMBLES, MODELS, ModelConfig, ensemble_member_kinds,
                                     make_model)
from terrain.tracking import require_store, tracked_run

#: Equal-weight votes scored when all their members were cross-validated.
VOTES = {kind: ensemble_member_kinds(ModelConfig(kind)) for kind in ENSEMBLES}


def training_run_share(groups: np.ndarray, folds: pd.DataFrame) -> float:
    """Mean share of the split units a fold's model is trained on.

    Parameters
    ----------
    groups : numpy.ndarray
        ``(n_windows,)`` split unit (run) of every window.
    folds : pandas.DataFrame
        Out-of-fold predictions with ``seed``, ``fold`` and ``group`` columns (the test
        windows of each fold).

    Returns
    -------
    float
        Mean over folds of ``1 - (test units / all units)``.
    """
    n = len(np.unique(groups))
    return float(np.mean([1.0 - g["group"].nunique() / n
                          for _, g in folds.groupby(["seed", "fold"])]))


def learning_curve_figure(table: pd.DataFrame, title: str = "") -> Figure:
    """Accuracy against the share of runs trained on, one line per model and history.

    Parameters
    ----------
    table : pandas.DataFrame
        The printed table: ``history``, ``model``, ``training_run_share``,
        ``accuracy_mean``, ``accuracy_std``.
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels (decision history 1 and 10 windows); error bars: spread over seeds.
    """
    fig = Figure(figsize=(10, 4.2))
    histories = sorted(table["history"].unique())
    axes = fig.subplots(1, len(histories), sharey=True, squeeze=False)[0]
    for ax, k in zip(axes, histories):
        for model, g in table[table["history"] == k].groupby("model", sort=False):
            g = g.sort_values("training_run_share")
            ax.errorbar(100 * g["training_run_share"], g["accuracy_mean"],
                        yerr=g["accuracy_std"], marker="o", capsize=3, label=model)
        ax.set_xlabel("runs trained on (% of the labelled runs)")
        ax.set_title(f"decision history k = {k}")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("run-grouped accuracy on held-out runs")
    axes[-1].legend(fontsize=8, loc="lower right")
    fig.suptitle(title, fontsize=10)
    return fig


def main() -> int:
    """Cross-validate at every number of folds, print and log the learning curve."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", choices=list(DATASET_SPECS), default="borealtc")
    parser.add_argument("--splits", type=integer_in(2, 1000), nargs="+", action=DistinctValues,
                        default=[2, 3, 5, 10])
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds,
                        default=[0, 1, 2])
    parser.add_argument("--models", nargs="+", action=DistinctValues, choices=MODELS,
                        default=["svm", "cnn", "cnn-spectrogram"])
    parser.add_argument("--max-epochs", type=positive_integer, default=30)
    parser.add_argument("--threads", type=positive_integer, default=1, help="torch threads per CNN")
    parser.add_argument("--out", type=output_file, default=None, help="write the table as CSV here")
    parser.add_argument("--figure", type=output_file, default=None, help="write the figure (PNG)")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    # with 10 folds some folds' test runs lack a class: their per-fold recall is undefined
    # (the pooled figures here do not use it)
    warnings.filterwarnings("ignore", message="y_pred contains classes not in y_true")
    blocks = CompareConfig().single_run_blocks
    rows = []
    for seed in args.seeds:
        ws, labels, groups = cell_windows(Cell("svm", "all", 2.0, args.dataset, seed),
                                          blocks)[:3]
        for n_splits in args.splits:
            preds, classes, fit_s = {}, None, {}
            for model in args.models:
                config = ModelConfig(model, max_epochs=args.max_epochs, n_threads=args.threads)
                t0 = time.perf_counter()
                report = cross_validate(
                    lambda s, config=config: make_model(config, ws.channels, ws.rate_hz,
                                                        args.dataset, s),
                    ws.X, labels, groups, ws.run_ids, ws.t_start_s, ws.t_end_s, "grouped",
                    (seed,), n_splits)
                fit_s[model] = (time.perf_counter() - t0) / n_splits
                preds[model], classes = report.predictions, report.classes
            share = training_run_share(groups, preds[args.models[0]])
            scored = dict(preds)
            for vote, members in VOTES.items():
                if all(m in preds for m in members):
                    scored[vote] = soft_vote([preds[m] for m in members], classes)
            for name, pred in scored.items():
                rows += score_rows(pred, classes, (1, 10),
                                   {"model": name, "seed": seed, "n_splits": n_splits,
                                    "training_run_share": share})
            print(f"seed {seed}, {n_splits} folds (trained on {share:.2f} of the runs): "
                  + ", ".join(f"{r['model']} {r['accuracy']:.3f}" for r in rows[-len(scored) * 2:]
                              if r["history"] == 1)
                  + " | fit s/fold " + ", ".join(f"{k} {v:.1f}" for k, v in fit_s.items()),
                  flush=True)
    scores = pd.DataFrame(rows)
    table = (scores.groupby(["history", "model", "n_splits"], sort=False)
             .agg(training_run_share=("training_run_share", "mean"),
                  accuracy_mean=("accuracy", "mean"), accuracy_std=("accuracy", "std"),
                  macro_f1_mean=("macro_f1", "mean"))
             .round(4).reset_index())
    pd.set_option("display.width", 160)
    print(f"{args.dataset}, run-grouped StratifiedGroupKFold(n), seeds {args.seeds}")
    print(table.to_string(index=False))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(args.out, index=False)
    fig = learning_curve_figure(table, f"{args.dataset}: accuracy on unseen runs against the "
                                       f"runs trained on (seeds {args.seeds})")
    if args.figure is not None:
        args.figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.figure, dpi=110, bbox_inches="tight")
    if not args.no_mlflow:
        params = {"dataset": args.dataset, "seeds": ",".join(map(str, args.seeds)),
                  "splits": ",".join(map(str, args.splits)), "models": ",".join(args.models),
                  "max_epochs": args.max_epochs, "window_s": 2.0, "signals": "all"}
        with tracked_run("terrain-benchmark", run_name="learning-curve-runs",
                         params=params) as run:
            run.log_metrics({f"{r.model}__n{r.n_splits}__k{r.history}__accuracy":
                             r.accuracy_mean for r in table.itertuples()})
            run.log_table(table, "learning_curve_runs.csv")
            run.log_table(scores, "learning_curve_runs_seeds.csv")
            run.log_figure(fig, "learning_curve_runs.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
