"""Compare every terrain classifier under one run-grouped protocol (MLflow parent + child runs).

Grid: model x signal set x window length x dataset x seed, each cell a
StratifiedGroupKFold(5) CV grouped by run; decision history k (probabilities averaged over the
last k windows of a run) reported for every cell. Cells run through joblib: --backend dask
--address tcp://HOST:8786 sends them to a Dask cluster, --backend ray to Ray, unchanged.
Writes compare_table.md/.csv (mean and spread over seeds), compare_cells.csv, predictions.csv
(every cell's out-of-fold windows, which benchmarks/merge_compare.py votes on) and compare.png
(and compare_grid.png / compare_grid.md, accuracy over signal set x window, when the grid
spans several; otherwise those of an earlier grid in --out are removed).
--protocol paper runs the papers' LEAKY 5 s partition protocol instead (1.7 s windows; labelled
as such in every table and run; never the default).
"""

from __future__ import annotations

import argparse
from dataclasses import asdict
from pathlib import Path

import pandas as pd

from pipelines.arguments import (DistinctSeeds, add_cnn_seeds, add_train_hop, integer_up_to,
                                 output_dir, parse_integer, positive_integer, positive_number,
                                 seed_value)
from terrain.errors import ConfigError
from terrain.io.jsonfile import staged_outputs, whole_file
from terrain.models.compare import (BACKENDS, COMPARE_PROTOCOLS, CompareConfig, check_backend,
                                    grid_markdown, iter_grid, joblib_backend, markdown_table,
                                    plot_comparison, plot_grid, spans_grid, summary_table)
from terrain.models.registry import MAX_TORCH_THREADS, MODELS, check_dependencies, cnn_kinds
from terrain.tracking import tracked_run

EXPERIMENT = "terrain-compare"
#: Files of --out that sum up compare_cells.csv: an earlier grid's are removed when this
#: grid's first cell replaces its cells, so that a grid stopped by an error leaves none
#: beside cells they do not describe.
SUMMARY_FILES = ("compare_table.md", "compare_table.csv", "compare.png", "predictions.csv",
                 "compare_grid.png", "compare_grid.md")
#: --quick: a small grid (2 models, Vulpi, 2 folds, 1 CNN epoch) for smoke tests.
QUICK = dict(models=("svm", "cnn"), signals=("all",), windows_s=(2.0,), datasets=("vulpi",),
             seeds=(0,), n_splits=2, max_epochs=1, n_threads=1)


def _address(value: str) -> str:
    """argparse ``type`` of ``--address``: a cluster address, not empty.

    Parameters
    ----------
    value : str
        The option's text (``tcp://host:8786`` for Dask, a Ray address).

    Returns
    -------
    str
        ``value`` unchanged.

    Raises
    ------
    argparse.ArgumentTypeError
        The value is empty or blank: ``--address $SCHEDULER`` with the variable unset ran
        the grid on a local cluster of this machine (an empty address is no address).
    """
    if not value.strip():
        raise argparse.ArgumentTypeError(
            "an empty address (give the scheduler's, e.g. tcp://host:8786, or leave --address "
            "out for a local cluster)")
    return value


def _n_jobs(value: str) -> int:
    """argparse ``type`` of ``--n-jobs``: joblib's worker count, any integer but 0 (-1:
    every worker; -2: all but one).

    Parameters
    ----------
    value : str
        The option's text.

    Returns
    -------
    int
        The count.

    Raises
    ------
    argparse.ArgumentTypeError
        Not an integer, or 0 (joblib has no meaning for it).
    """
    number = parse_integer(value, "an integer, got ")
    if number == 0:
        raise argparse.ArgumentTypeError("0 workers cannot run a cell: give -1 (every "
                                         "worker of the backend), 1 (sequential) or more")
    return number


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain compare``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser, extended in place.
    """
    d = CompareConfig()
    parser.add_argument("--models", nargs="+", choices=MODELS, default=list(d.models))
    parser.add_argument("--signals", nargs="+", default=list(d.signals))
    parser.add_argument("--windows-s", type=positive_number, nargs="+",
                        default=list(d.windows_s))
    parser.add_argument("--datasets", nargs="+", default=list(d.datasets))
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds,
                        default=list(d.seeds))
    parser.add_argument("--history", type=positive_integer, nargs="+", default=list(d.history),
                        help="decision histories k reported for every cell: the class of the "
                             "probabilities averaged over the last k windows of a run")
    parser.add_argument("--max-epochs", type=positive_integer, default=d.max_epochs)
    parser.add_argument("--threads", type=integer_up_to(MAX_TORCH_THREADS), default=None,
                        help="torch threads per CNN fit")
    parser.add_argument("--protocol", choices=COMPARE_PROTOCOLS, default=d.protocol,
                        help="grouped: run-grouped StratifiedGroupKFold (headline); paper: the "
                             "BorealTC/Vulpi papers' LEAKY 5 s partition protocol (needs "
                             "--windows-s 1.7; partitions of one run on both sides of a split)")
    parser.add_argument("--early-stopping", action="store_true",
                        help="CNNs stop on the loss of whole training runs held out of each "
                             "fit (--max-epochs is the upper bound); default: fixed budget")
    add_cnn_seeds(parser, d.cnn_seeds)
    add_train_hop(parser)
    parser.add_argument("--quick", action="store_true",
                        help="small grid (smoke test: 2 models, Vulpi, 2 folds, 1 CNN epoch); "
                             "refuses the grid and training options it replaces")
    parser.add_argument("--backend", choices=BACKENDS, default="loky")
    parser.add_argument("--address", type=_address, default=None,
                        help="Dask scheduler (tcp://host:8786) or Ray address; "
                             "default: a local cluster")
    parser.add_argument("--n-jobs", type=_n_jobs, default=-1,
                        help="joblib workers, any integer but 0 (-1: all of the backend; -2: "
                             "all but one, and so on; 1: sequential here)")
    parser.add_argument("--out", type=output_dir, default=Path("compare"), help="output folder")
    parser.add_argument("--no-progress", action="store_true",
                        help="hide the progress bar over grid cells")


def config_from_args(args: argparse.Namespace) -> CompareConfig:
    """The grid from parsed arguments (``--quick`` replaces the axes).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed ``terrain compare`` arguments.

    Returns
    -------
    CompareConfig
        The grid.

    Raises
    ------
    ConfigError
        ``--quick`` with a grid option it would ignore, ``--early-stopping``,
        ``--max-epochs`` or ``--threads`` with no CNN in ``--models`` (they train the CNNs
        only), or a grid
        :class:`~terrain.models.compare.CompareConfig` refuses.
    """
    if args.quick:
        d = CompareConfig()
        given = [f"--{name.replace('_', '-')}" for name, value, default in (
            ("models", args.models, d.models), ("signals", args.signals, d.signals),
            ("windows_s", args.windows_s, d.windows_s), ("datasets", args.datasets,
                                                         d.datasets),
            ("seeds", args.seeds, d.seeds), ("max_epochs", args.max_epochs, d.max_epochs),
            ("threads", args.threads, d.n_threads),
            # the quick grid's CNNs train its fixed 1-epoch budget
            ("early_stopping", args.early_stopping, d.early_stopping))
            if (tuple(value) if isinstance(value, list) else value) != default]
        if given:
            raise ConfigError(f"--quick runs its own small grid and would ignore {given}: "
                              "drop --quick or those options")
        quick = {**QUICK, **({"windows_s": (1.7,)} if args.protocol == "paper" else {})}
        return CompareConfig(**quick, history=tuple(args.history), protocol=args.protocol,
                             train_hop_s=args.train_hop_s, cnn_seeds=args.cnn_seeds)
    d = CompareConfig()
    unused = [option for option, value, default in (
        ("--early-stopping", args.early_stopping, d.early_stopping),
        ("--max-epochs", args.max_epochs, d.max_epochs), ("--threads", args.threads, None))
        if value != default]
    if unused and not any(cnn_kinds(model) for model in args.models):
        # they train the CNNs only: ignored, and logged to MLflow as if used
        raise ConfigError(f"{', '.join(unused)} train{'s' if len(unused) == 1 else ''} the "
                          f"CNNs and none of the models {list(args.models)} has one: leave "
                          f"{'it' if len(unused) == 1 else 'them'} out")
    return CompareConfig(models=tuple(args.models), signals=tuple(args.signals),
                         windows_s=tuple(args.windows_s), datasets=tuple(args.datasets),
                         seeds=tuple(args.seeds), history=tuple(args.history),
                         max_epochs=args.max_epochs, n_threads=args.threads,
                         protocol=args.protocol, early_stopping=args.early_stopping,
                         train_hop_s=args.train_hop_s, cnn_seeds=args.cnn_seeds)


def log_cell(result: dict) -> None:
    """Log one finished cell as a child run of the active ``compare`` run.

    Through :func:`terrain.tracking.tracked_run` (a child of the caller's active run), so
    the cell follows the rules of every other run: ``code_version`` logged, non-finite
    metrics skipped and listed in the tag ``non_finite_metrics``.

    Parameters
    ----------
    result : dict
        A :func:`terrain.models.compare.run_cell` result.
    """
    c = result["cell"]
    name = (f"{c['model']}-{c['dataset']}-{c['signals']}-{c['window_s']:g}s-seed{c['seed']}"
            + ("" if c["protocol"] == "grouped" else f"-{c['protocol']}-LEAKY")
            + ("" if c["train_hop_s"] is None else f"-trainhop{c['train_hop_s']:g}s"))
    with tracked_run(EXPERIMENT, run_name=name, params=c, announce=False) as child:
        child.log_metrics({f"{m}_k{r['history']}": float(r[m]) for r in result["rows"]
                           for m in ("accuracy", "balanced_accuracy", "macro_f1",
                                     "run_vote_accuracy")})
        child.log_metrics({k: float(result["rows"][0][k]) for k in
                           ("fit_s_per_fold", "infer_ms_per_window", "n_windows_dropped")})


def main(args: argparse.Namespace) -> int:
    """Run the grid, log the parent and child runs, write the table and figure.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed ``terrain compare`` arguments.

    Returns
    -------
    int
        Exit status (0).
    """
    check_backend(args.backend, args.address)      # before any run opens
    config = config_from_args(args)
    for model in config.models:               # optional extras, before any run opens
        check_dependencies(model)
    params = {k: ",".join(map(str, v)) if isinstance(v, tuple) else v
              for k, v in asdict(config).items()}
    cells = config.cells()
    args.out.mkdir(parents=True, exist_ok=True)
    with tracked_run(EXPERIMENT, run_name="compare", params={**params,
                                                             "backend": args.backend}) as run:
        results = []
        with joblib_backend(args.backend, args.address) as n_jobs:
            finished = iter_grid(config, n_jobs=n_jobs if args.n_jobs == -1 else args.n_jobs)
            if not args.no_progress:
                from tqdm.auto import tqdm
                finished = tqdm(finished, total=len(cells), desc="compare", unit="cell")
            for res in finished:
                # each cell is logged and saved when it finishes, so a long grid that stops
                # early keeps what it measured (child runs and compare_cells.csv)
                log_cell(res)
                if not results:     # the earlier grid's cells go now: so does what sums them
                    for name in SUMMARY_FILES:
                        (args.out / name).unlink(missing_ok=True)
                results.append(res)
                with whole_file(args.out / "compare_cells.csv") as tmp:
                    pd.DataFrame([r for done in results for r in done["rows"]]).to_csv(
                        tmp, index=False)
        rows = pd.DataFrame([r for res in results for r in res["rows"]])
        table = summary_table(rows)
        md = markdown_table(table)
        # the summary lands whole or not at all, the tables last; an earlier, larger grid's
        # figure would stand beside this table as its own, so a file not written goes
        with staged_outputs(args.out, SUMMARY_FILES,
                            last=("compare_table.csv", "compare_table.md")) as stage:
            (stage / "compare_table.md").write_text(md)
            table.to_csv(stage / "compare_table.csv", index=False)
            fig = plot_comparison(table)
            fig.savefig(stage / "compare.png", dpi=120)
            for name in ("compare_table.md", "compare_table.csv"):
                run.log_artifact(stage / name)
            run.log_artifact(args.out / "compare_cells.csv")
            run.log_figure(fig, "compare.png")
            if spans_grid(table):
                grid = plot_grid(table)
                grid.savefig(stage / "compare_grid.png", dpi=120, bbox_inches="tight")
                run.log_figure(grid, "compare_grid.png")
                (stage / "compare_grid.md").write_text(grid_markdown(table, config.history))
                run.log_artifact(stage / "compare_grid.md")
            pd.concat([r["predictions"] for r in results]).to_csv(stage / "predictions.csv",
                                                                  index=False)
    print(md)
    # once per distinct note (every seed and model of a dataset cuts the same blocks)
    for note in dict.fromkeys(n for res in results for n in res.get("notes", ())):
        print(f"note: {note}")
    print(f"{len(results)} cells; table, cells, predictions and figure in {args.out}")
    print(run.describe())
    return 0
