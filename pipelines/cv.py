"""Cross-validate a terrain classifier (--model, default SVM) on a shipped dataset (MLflow-tracked).

Headline protocol: StratifiedGroupKFold(5) grouped by run, 3 seeds. --protocol paper runs the
published BorealTC/Vulpi protocol (5 s partitions, StratifiedKFold(5, shuffle, random_state=21),
1.7 s windows at 0.1 s hop): it leaks runs between train and test, so it is a secondary line.
"""

from __future__ import annotations

import argparse
import json

from pipelines.arguments import (DistinctSeeds, add_cnn_seeds, add_run_balanced, add_train_hop,
                                 add_window_ekf, output_file, positive_number, seed_value)
from terrain.errors import ConfigError
from terrain.io.jsonfile import json_ready, whole_file
from terrain.io.report import input_report
from terrain.io.shipped import DATASET_SPECS, load_dataset
from terrain.models.cv import PROTOCOLS
from terrain.models.experiment import PAPER_WINDOW, ExperimentConfig, ExperimentResult, run_cv
from terrain.models.metrics import plot_confusion
from terrain.models.registry import MODELS, check_dependencies
from terrain.tracking import tracked_run

EXPERIMENT = "terrain-cv"
HEADLINE = ("accuracy", "balanced_accuracy", "macro_f1", "run_majority_accuracy")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain cv``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser to which the options are added (modified in place).
    """
    parser.add_argument("--dataset", choices=list(DATASET_SPECS), default="borealtc")
    parser.add_argument("--model", choices=MODELS, default="svm",
                        help="classifier (default: svm; see README 'Model comparison')")
    parser.add_argument("--signals", nargs="+", default=["all"],
                        help="imu, wheels, all, all-no-speed (all but the forward wheel "
                             "speeds), ekf (EKF-derived channels), all+ekf, or channel names "
                             "(default: all)")
    parser.add_argument("--window-s", type=positive_number, default=None,
                        help="window length, s (default: 2.0); the paper protocol fixes 1.7")
    parser.add_argument("--hop-s", type=positive_number, default=None,
                        help="hop between windows, s (default: window length)")
    add_train_hop(parser)
    parser.add_argument("--protocol", choices=PROTOCOLS, default="grouped")
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds, default=None,
                        help="CV seeds (default: 0 1 2; loro: 0, it is deterministic; "
                             "paper: 0, i.e. random_state 21)")
    parser.add_argument("--search", action="store_true",
                        help="nested grouped grid search of C and gamma in each training fold")
    add_cnn_seeds(parser)
    add_window_ekf(parser)
    add_run_balanced(parser)
    parser.add_argument("--steady-only", action="store_true",
                        help="keep steady-motion windows only (thesis ch. 8.1)")
    parser.add_argument("--json", type=output_file, default=None,
                        help="write the report as JSON")
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")


def config_from_args(args: argparse.Namespace) -> ExperimentConfig:
    """Build the experiment configuration from parsed arguments.

    Without ``--seeds``, the ``paper`` and ``loro`` protocols use seed 0 (leave-one-run-out is
    deterministic; seed 0 is the paper protocol's published split), the others seeds 0, 1, 2.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    ExperimentConfig
        The configuration handed to :func:`terrain.models.experiment.run_cv`.

    Raises
    ------
    ConfigError
        ``--window-s`` or ``--hop-s`` given with the paper protocol (it fixes its windows),
        or any check of :class:`~terrain.models.experiment.ExperimentConfig`.
    """
    if args.protocol == "paper" and (args.window_s not in (None, PAPER_WINDOW["window_s"])
                                     or args.hop_s not in (None, PAPER_WINDOW["hop_s"])):
        raise ConfigError(f"the paper protocol fixes its windows ({PAPER_WINDOW['window_s']:g}"
                          f" s every {PAPER_WINDOW['hop_s']:g} s): drop --window-s / --hop-s")
    # leave-one-run-out is deterministic; the paper protocol's published split is seed 0
    seeds = args.seeds or ([0] if args.protocol in ("paper", "loro") else [0, 1, 2])
    return ExperimentConfig(dataset=args.dataset, signals=tuple(args.signals),
                            window_s=2.0 if args.window_s is None else args.window_s,
                            hop_s=args.hop_s,
                            train_hop_s=args.train_hop_s, protocol=args.protocol,
                            seeds=tuple(seeds), search=args.search,
                            steady_only=args.steady_only, model=args.model,
                            window_ekf=args.window_ekf, cnn_seeds=args.cnn_seeds,
                            run_balanced=args.run_balanced)


def result_dict(result: ExperimentResult) -> dict:
    """The JSON report of a CV run.

    Parameters
    ----------
    result : ExperimentResult
        Outcome of :func:`terrain.models.experiment.run_cv`.

    Returns
    -------
    dict
        JSON-serialisable report: ``config``, ``n_windows``, ``n_runs``, ``classes``,
        ``metrics`` (mean/std per metric over folds), ``pooled`` (mean/std over seeds of the
        pooled out-of-fold metrics), ``pooled_by_seed``, ``confusion`` (labels and counts
        summed over seeds), ``notes``, ``timings_s`` (s) and ``headline`` (False for the leaky
        ``paper`` protocol).
    """
    rep = result.report
    return {
        "config": result.config.as_params(),
        "n_windows": result.n_windows, "n_runs": result.n_runs, "classes": rep.classes,
        "metrics": rep.summary(),
        "pooled": {k: {"mean": float(rep.pooled[k].mean()),
                       "std": float(rep.pooled[k].std(ddof=0))}
                   for k in rep.pooled.columns if k != "seed"},
        "pooled_by_seed": rep.pooled.to_dict(orient="records"),
        "confusion": {"labels": rep.classes, "counts": rep.confusion.to_numpy().tolist()},
        "notes": rep.notes, "timings_s": result.timings_s,
        "headline": result.config.protocol != "paper",
    }


def pooled_recall(confusion) -> dict[str, float]:
    """Per-class recall of the pooled out-of-fold predictions.

    Parameters
    ----------
    confusion : pandas.DataFrame
        Confusion counts (rows true class, columns predicted), summed over seeds.

    Returns
    -------
    dict
        Class -> diagonal / row sum; NaN for a class with no window.
    """
    counts = confusion.to_numpy().astype(float)
    rows = counts.sum(axis=1)
    return {str(c): float(counts[i, i] / rows[i]) if rows[i] else float("nan")
            for i, c in enumerate(confusion.index)}


def main(args: argparse.Namespace) -> int:
    """Run the CV, log it to MLflow, print the summary.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        Exit status, 0 on success. Data and configuration errors (:mod:`terrain.errors`)
        raised while loading the dataset propagate to the CLI, which prints them on one line.
    """
    config = config_from_args(args)
    name = (f"{config.model}-{config.dataset}-{config.protocol}-{'+'.join(config.signals)}"
            + (f"+cnn-seeds{config.cnn_seeds}" if config.cnn_seeds > 1 else "")
            + ("+run-balanced" if config.run_balanced else ""))
    check_dependencies(config.model)     # an optional extra missing: before any data
    runs = load_dataset(config.dataset)  # a data error stops here, before any MLflow run
    with tracked_run(EXPERIMENT, run_name=name, params=config.as_params()) as run:
        result = run_cv(config, runs=runs, progress=not args.no_progress)
        rep = result.report
        summary = rep.summary()
        inputs = input_report(runs, result.counts, config.window_config().window_s)
        recall = pooled_recall(rep.confusion)
        metrics = {f"{k}_mean": v["mean"] for k, v in summary.items()}
        metrics.update({f"{k}_std": v["std"] for k, v in summary.items()})
        # a class's recall is averaged over the folds that test it: how many, beside it
        metrics.update({f"{k}_n_folds": v["n_folds"] for k, v in summary.items()
                        if k.startswith("recall_")})
        metrics.update({f"{k}_pooled": float(rep.pooled[k].mean()) for k in HEADLINE})
        metrics.update({f"recall_{c}_pooled": v for c, v in recall.items()})
        metrics.update(inputs.metrics())
        run.log_table(inputs.table, "input_report.csv")
        metrics.update({f"time_{k}": v for k, v in result.timings_s.items()})
        metrics.update(n_windows=result.n_windows, n_runs=result.n_runs)
        run.log_metrics(metrics)
        run.log_table(rep.confusion.reset_index(), "confusion_matrix.csv")
        n_seeds = len(rep.pooled)
        run.log_figure(plot_confusion(rep.confusion, f"{name}: out-of-fold counts summed over "
                                      f"{n_seeds} seed(s)"), "confusion_matrix.png")
        run.log_table(rep.predictions, "predictions.csv")
        run.log_table(rep.folds, "folds.csv")
        report = result_dict(result)
        report["pooled_recall"] = recall
        report["mlflow_run_id"] = run.run_id
        run.log_dict(report, "cv_report.json")
    line = "secondary (leaky) protocol" if config.protocol == "paper" else "headline"
    signals = ",".join(config.signals) + (" + EKF per window" if config.window_ekf else "")
    model = (config.model + (f" ({config.cnn_seeds} networks per CNN)"
                             if config.cnn_seeds > 1 else "")
             + (" (run-balanced)" if config.run_balanced else ""))
    print(f"{model} / {config.dataset} / {config.protocol} ({line}) / signals {signals}: "
          f"{result.n_windows} windows from {result.n_runs} runs, {len(rep.classes)} classes")
    pooled = rep.pooled
    print(f"  {'metric':24s} {'pooled out-of-fold':>22s}   {'per fold':>22s}")
    for k in HEADLINE:
        s = summary[k]
        print(f"  {k:24s} {pooled[k].mean():.3f} +- {pooled[k].std(ddof=0):.3f} "
              f"({len(pooled)} seeds)   {s['mean']:.3f} +- {s['std']:.3f} "
              f"(min {s['min']:.3f}, max {s['max']:.3f})")
    print(f"  pooled per-class recall (confusion matrix, counts summed over {len(pooled)} "
          f"seed(s)): {', '.join(f'{c} {v:.2f}' for c, v in recall.items())}")
    n_folds = len(rep.folds)
    recalls = ", ".join(
        f"{k[7:]} {v['mean']:.2f}"
        + (f" ({v['n_folds']} of {n_folds} folds)" if v["n_folds"] < n_folds else "")
        for k, v in summary.items() if k.startswith("recall_"))
    print(f"  per-class recall, mean over the folds holding the class: {recalls}")
    print(inputs.text())
    for note in rep.notes:
        if note not in result.input_notes:  # the input report above says these
            print(f"  note: {note}")
    print(f"  timings: {', '.join(f'{k} {v:.1f}' for k, v in result.timings_s.items())}")
    if args.json:
        # strict JSON (RFC 8259): an undefined figure (the recall of a class without a
        # window) is null, not the bare token NaN that jq and JSON.parse refuse; whole or
        # not at all (a full disk left a file cut short, and the earlier report lost)
        text = json.dumps(json_ready(report, None), indent=1, default=str,
                          allow_nan=False) + "\n"
        with whole_file(args.json) as tmp:
            tmp.write_text(text)
        print(f"  report written to {args.json}")
    print(run.describe())
    return 0
