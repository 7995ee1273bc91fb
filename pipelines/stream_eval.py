"""Evaluate streaming terrain decisions run-grouped (wheel-only window CV, held-out streams).

* wheel-cv: wheel-only (vel_l, vel_r, cur_l, cur_r) window accuracy on BorealTC with the
  drive-physics features and extremely randomised trees, StratifiedGroupKFold(5) grouped by
  run, seeds pooled; decisions every --hop-s with --window-s of history, raw and after the
  forward filter.
* streams: for each fold, runs held out of training are strung into one stream of terrain
  switches every 30-120 s (seeded) and replayed sample by sample through the service;
  per-decision accuracy and median switching delay for each --kinds recipe (default: the
  default all-signal and wheel-only recipes), for several smoothing settings.
Results are logged to MLflow (experiment terrain-stream-eval). --model-out saves the
streaming models fitted on every run (model directories for ``terrain stream``).
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace

import pandas as pd

from features.windows import WindowConfig
from pipelines.arguments import DistinctSeeds, model_dir, output_dir, positive_number, seed_value
from terrain.errors import ConfigError, duplicated
from terrain.io.shipped import load_dataset
from terrain.serving.pyfunc import save_model
from terrain.serving.evaluation import (encode_stream_scores, held_out_folds,
                                        held_out_streams, pool_scores, recipe_stream_names,
                                        runs_holding, seed_accuracies, window_cv)
from terrain.serving.recipes import DEFAULT_RECIPES, RECIPES, fit_stream_model
from terrain.serving.smoothing import SmoothingConfig
from terrain.tracking import tracked_run

EXPERIMENT = "terrain-stream-eval"
#: default hop of the wheel-cv part's windows, s (non-overlapping 2 s decisions)
WHEEL_CV_HOP_S = 2.0
#: default folds over runs of the held-out streams (the headline protocol)
STREAM_FOLDS = 5
#: smoothing settings scored on the same replayed decisions: none, hysteresis alone (a
#: margin on the window's own probabilities), the forward filter alone, and both
SMOOTHINGS = {"raw": SmoothingConfig(dwell_s=None),
              **{f"raw_hyst{h:g}": SmoothingConfig(dwell_s=None, hysteresis=h)
                 for h in (0.1, 0.2, 0.3, 0.5)},
              **{f"dwell{d:g}_power{p:g}": SmoothingConfig(dwell_s=d, evidence_power=p)
                 for d in (5.0, 10.0, 30.0, 60.0) for p in (0.2, 0.5, 1.0)},
              **{f"dwell{d:g}_power{p:g}_hyst{h:g}": SmoothingConfig(
                  dwell_s=d, evidence_power=p, hysteresis=h)
                 for d, p in ((5.0, 0.5), (10.0, 0.5), (30.0, 0.2)) for h in (0.1, 0.2)}}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain stream-eval``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser to which the options are added (modified in place).
    """
    parser.add_argument("--part", choices=["wheel-cv", "streams", "both", "none"],
                        default="both")
    parser.add_argument("--model-out", type=output_dir, default=None,
                        help="also fit each --kinds recipe on every BorealTC run and save it "
                             "to DIR/<kind> (a model directory for terrain stream)")
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds,
                        default=None,
                        help="seeds of the wheel CV's folds and of the held-out streams "
                             "(default 0 1 2)")
    parser.add_argument("--kinds", nargs="+", choices=list(RECIPES),
                        default=None,
                        help="recipes of the held-out stream evaluation and of --model-out "
                             "(all: window statistics + SVM; all-ensemble: + spectrogram CNN, "
                             "soft vote; all-ensemble3: + raw CNN as well; wheels: physics "
                             "features + extra trees; default: the default recipe per signal "
                             "set)")
    parser.add_argument("--window-s", type=positive_number, default=None,
                        help="wheel-cv window (history) length, s (default: the wheels "
                             f"recipe's, {RECIPES['wheels'].window_s:g} s)")
    parser.add_argument("--hop-s", type=positive_number, default=None,
                        help=f"wheel-cv hop, s (default {WHEEL_CV_HOP_S:g})")
    parser.add_argument("--folds", type=int, default=None,
                        help="folds over runs of the held-out streams: each fold's model is "
                             "trained on (N-1)/N of the runs and its held-out runs are one "
                             "stream (default 5, the headline protocol; more folds train on "
                             "more runs, closer to a model trained on every shipped run)")
    parser.add_argument("--switch-gap-s", type=float, default=None,
                        help="dropout added at every terrain switch of the held-out streams, "
                             "s (default 0: the clock runs on across a switch, as on a robot "
                             "driving onto the next terrain; before, 0.1 s, which the service "
                             "flags as a gap on the 100 Hz IMU)")
    parser.add_argument("--no-progress", action="store_true",
                        help="hide progress bars (the held-out streams' bar over the folds)")


def resolve_options(args: argparse.Namespace) -> None:
    """Check the options against each other and fill the defaults of those left out.

    An option that shapes a part ``--part`` does not run is refused rather than ignored
    (and logged to MLflow as if used); the defaults (``--seeds 0 1 2``, ``--folds 5``,
    ``--switch-gap-s 0``, the wheels recipe's window and hop, the default recipe per signal
    set) are filled in place. Nothing is read.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`; modified in place.

    Raises
    ------
    ConfigError
        ``--part none`` without ``--model-out``, a recipe repeated in ``--kinds``,
        ``--folds`` below 2, a ``--window-s`` or ``--hop-s`` that
        :class:`~features.windows.WindowConfig` refuses, or either given with a ``--part``
        that does not run the wheel CV, ``--folds`` or ``--switch-gap-s`` given with a
        ``--part`` that runs no held-out stream, ``--seeds`` with ``--part none``,
        ``--kinds`` with ``--part wheel-cv`` and no ``--model-out``, a
        negative or infinite ``--switch-gap-s``, a ``--model-out`` folder of a recipe that
        is not empty.
    """
    if args.part == "none" and args.model_out is None:   # an empty MLflow run, nothing done
        raise ConfigError("--part none evaluates nothing and only saves the --model-out "
                          "models: give --model-out DIR, or another --part")
    wheel_cv = args.part in ("wheel-cv", "both")
    given = [o for o, v in (("--window-s", args.window_s), ("--hop-s", args.hop_s))
             if v is not None]
    if given and not wheel_cv:   # they were ignored (and logged to MLflow as if used)
        raise ConfigError(f"{' and '.join(given)} set the wheel-cv part's windows; --part "
                          f"{args.part} does not run it")
    streams = args.part in ("streams", "both")
    if args.seeds is not None and args.part == "none":  # ignored, and logged as if used
        raise ConfigError("--seeds seed the wheel CV and the held-out streams; --part none "
                          "runs neither")
    if args.seeds is None:
        args.seeds = [0, 1, 2]
    for option, value in (("--folds", args.folds), ("--switch-gap-s", args.switch_gap_s)):
        if value is not None and not streams:   # ignored, and logged to MLflow as if used
            raise ConfigError(f"{option} shapes the held-out streams; --part {args.part} does "
                              "not run them")
    if args.folds is None:
        args.folds = STREAM_FOLDS
    if args.switch_gap_s is None:
        args.switch_gap_s = 0.0
    if args.window_s is None:
        args.window_s = RECIPES["wheels"].window_s
    if args.hop_s is None:
        args.hop_s = WHEEL_CV_HOP_S
    if args.kinds is not None and not (streams or args.model_out):   # ignored unsaid
        raise ConfigError(f"--kinds chooses the recipes of the held-out streams and of "
                          f"--model-out; --part {args.part} without --model-out uses neither")
    if args.kinds is None:
        args.kinds = list(DEFAULT_RECIPES.values())
    repeated = duplicated(args.kinds)
    if repeated:  # each would be fitted and logged twice under one name
        raise ConfigError(f"--kinds: {repeated} given more than once")
    if args.folds < 2:
        raise ConfigError(f"--folds must be at least 2 (a model needs runs to train on and "
                          f"runs held out), got {args.folds}")
    # the wheel-cv windows' checks, at the wheel recipe's clock rate they are cut at
    WindowConfig(window_s=args.window_s, hop_s=args.hop_s, rate_hz=RECIPES["wheels"].rate_hz)
    if not 0 <= args.switch_gap_s < math.inf:
        raise ConfigError(f"--switch-gap-s must be a finite number of seconds >= 0, got "
                          f"{args.switch_gap_s}")
    for kind in args.kinds if args.model_out else []:  # before hours of evaluation
        try:
            model_dir(str(args.model_out / kind))
        except argparse.ArgumentTypeError as exc:
            raise ConfigError(f"--model-out: {exc}") from None


def main(args: argparse.Namespace) -> int:
    """Run the chosen parts, print and log them.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments` (left as they are: the defaults are
        filled in a copy).

    Returns
    -------
    int
        Exit status, 0 on success.

    Raises
    ------
    ConfigError
        An option :func:`resolve_options` refuses (before any run is read); more
        ``--folds`` than runs to cut the streams from (once the runs are read, before any
        model is fitted).
    """
    # (a copy: the defaults filled in the caller's Namespace read as given options, and
    # the same arguments run again were refused)
    args = argparse.Namespace(**vars(args))
    resolve_options(args)   # before any run is read
    wheel_cv, streams = args.part in ("wheel-cv", "both"), args.part in ("streams", "both")
    runs = load_dataset("borealtc")
    for kind in args.kinds if streams else []:
        check_folds(runs, kind, args.seeds, args.folds, args.switch_gap_s)
    report: dict = {}
    with tracked_run(EXPERIMENT, run_name=f"stream-eval-{args.part}",
                     params={"part": args.part,
                             **({"seeds": ",".join(map(str, args.seeds))}
                                if args.part != "none" else {}),
                             # the held-out streams' settings, only where they are scored
                             **({"switch_gap_s": args.switch_gap_s, "folds": args.folds}
                                if streams else {}),
                             # the wheel-cv windows, only where that part runs
                             **({"window_s": args.window_s, "hop_s": args.hop_s}
                                if wheel_cv else {}),
                             # the recipes, only where streams are scored or models saved
                             **({"kinds": ",".join(args.kinds)}
                                if args.part in ("streams", "both") or args.model_out
                                else {})}) as run:
        if wheel_cv:
            recipe = replace(RECIPES["wheels"], window_s=args.window_s)
            cv = window_cv(runs, recipe, args.hop_s, args.seeds, SMOOTHINGS)
            report["wheel_cv"] = cv
            run.log_metrics({f"wheel_cv_{k}": v for k, v in cv["pooled_accuracy"].items()})
            run.log_metrics({f"wheel_cv_run_mean_{k}": v
                             for k, v in cv["run_mean_accuracy"].items()})
            for name, acc in cv["pooled_accuracy"].items():
                print(f"wheel-only window accuracy ({cv['n_windows']} windows of "
                      f"{args.window_s:g} s every {args.hop_s:g} s, {len(args.seeds)} seeds "
                      f"pooled), {name}: {acc:.3f} (mean over runs "
                      f"{cv['run_mean_accuracy'][name]:.3f}; "
                      f"{cv['n_undecided'][name]} windows without a decision, counted wrong)")
        if args.part in ("streams", "both"):
            for kind in args.kinds:
                frames = [held_out_streams(runs, RECIPES[kind], seed, SMOOTHINGS,
                                           n_splits=args.folds,
                                           switch_gap_s=args.switch_gap_s,
                                           progress=not args.no_progress)
                          .assign(seed=seed) for seed in args.seeds]
                res = pd.concat(frames, ignore_index=True)
                run.log_table(encode_stream_scores(res), f"held_out_streams_{kind}.csv")
                summary = {name: {**pool_scores(g), "accuracy_per_seed": seed_accuracies(g)}
                           for name, g in res.groupby("smoothing")}
                for name, row in summary.items():
                    run.log_metrics({f"{kind}_{name}_{k}": v for k, v in row.items()
                                     if k in ("accuracy", "median_delay_s",
                                              "accuracy_settled")})
                    run.log_metrics({f"{kind}_{name}_accuracy_seed{seed}": v
                                     for seed, v in row["accuracy_per_seed"].items()})
                    per_seed = " / ".join(f"{v:.3f}" for v in row["accuracy_per_seed"].values())
                    print(f"held-out streams, {kind}, {name}: per-decision accuracy "
                          f"{row['accuracy']:.3f} (settled windows {row['accuracy_settled']:.3f}),"
                          f" median switching delay {row['median_delay_s']:.1f} s "
                          f"({row['n_switches']} switches, {args.folds} folds, "
                          f"{len(args.seeds)} seeds pooled; per seed {per_seed}); "
                          f"recall {_fmt(row['recall'])}")
                report[f"streams_{kind}"] = summary
        vehicles = sorted({r.vehicle for r in runs})
        for kind in args.kinds if args.model_out else []:
            model = fit_stream_model(RECIPES[kind], runs)
            # the fitted model's own metadata (the track its windows used, the training
            # runs' sample steps that judge a live stream's first steps) and the runs'
            # vehicle, as `terrain train` saves them: `terrain stream` reads them back
            path = save_model(args.model_out / kind, model.pipeline, model.channels,
                              model.window, list(model.classes),
                              {**model.metadata, "dataset": "borealtc",
                               "vehicle": vehicles[0] if len(vehicles) == 1 else None,
                               "recipe": str(RECIPES[kind])})
            print(f"saved the {kind} streaming model to {path}")
        run.log_dict(report, "stream_eval.json")
    if report:  # --part none only saves models
        print(json.dumps(report, indent=1, default=str)[:2000])
    print(run.describe())
    return 0


def check_folds(runs, kind: str, seeds, folds: int, switch_gap_s: float) -> None:
    """Refuse, before the wheel CV and any fit, a ``--folds`` the held-out streams of a
    recipe cannot be cut with: the folds and streams of every seed are cut as
    :func:`terrain.serving.evaluation.held_out_streams` cuts them (a fraction of a second
    each), so what would stop them stops the command here.

    At most as many folds as runs (every fold holds one out) is not enough: the stratified
    split by run takes no more folds than the largest class has runs (22 of BorealTC's 55
    wheel runs are SNOW: ``--folds 23`` ran the wheel CV, then failed), and each fold's
    held-out stream needs runs of two terrains.

    Parameters
    ----------
    runs : sequence of Run
        The dataset's runs.
    kind : str
        Recipe of :data:`terrain.serving.recipes.RECIPES`.
    seeds : sequence of int
        ``--seeds``.
    folds : int
        ``--folds``.
    switch_gap_s : float
        ``--switch-gap-s``, s.

    Raises
    ------
    ConfigError
        ``--folds N over the M runs the <kind> streams are cut from (seed S): <why>``.
    """
    names = recipe_stream_names(RECIPES[kind])
    for seed in seeds:
        try:
            for _ in held_out_folds(runs, names, seed, n_splits=folds,
                                    switch_gap_s=switch_gap_s):
                pass
        except ConfigError as exc:
            raise ConfigError(f"--folds {folds} over the {len(runs_holding(runs, names))} "
                              f"runs the {kind} streams are cut from (seed {seed}): {exc}"
                              ) from None


def _fmt(recall: dict) -> str:
    """Per-class recall as ``CLASS 0.93, ...``."""
    return ", ".join(f"{k} {v:.2f}" for k, v in recall.items())
