"""Fit the learned slip model on simulated Husky runs; compare it with the physics and seed models.

Simulates (once; cached under --cache-dir) a grid terrains x scenarios x seeds, cuts 2 s
windows, fits the learned model (terrain.slip.learned) on the --train-seeds and scores every
model on the --test-seeds, grouped by run: held out by seed, leave-one-scenario-out and
leave-one-terrain-out (proprioceptive features only, no terrain knowledge; and with the physics
slip kept: the unseen ground's catalogue curve known, no data from it). Also reports
slip-compensated dead reckoning on the held-out orchard and slope_turn runs. Everything is
logged to MLflow (experiment terrain-slip-fit); the model is registered as slip-<vehicle>.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from features.slip_features import (SLIP_WINDOW, one_hot_probabilities, slip_features,
                                    slip_table, slip_windows, terrain_columns)
from pipelines.arguments import (DistinctSeeds, DistinctValues, option_params, output_dir,
                                 seed_value, terrain_name)
from pipelines.slip_model import REGISTERED_SLIP_MODEL
from terrain.errors import ConfigError
from terrain.io.jsonfile import staged_outputs, strict_json
from terrain.io.shipped import DATASET_SPECS, load_dataset
from terrain.slip.dataset import SlipDataSpec, simulated_runs
from terrain.slip.evaluation import (baseline_predictions, error_table, leave_one_out,
                                     measured_checks, odometry_errors, std_calibration_table,
                                     steady_straight)
from terrain.slip.figures import error_figure, odometry_figure
from terrain.slip.learned import SLIP_OUTPUTS, SlipRegressor
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.tracking import tracked_run
from terrain.vehicles import get_vehicle

EXPERIMENT = "terrain-slip-fit"
TARGET_TERRAINS = ("ASPHALT", "SANDY_LOAM", "SNOW", "ICE", "GRASS")
#: Types inside the logged model that the skops serialiser must accept (our own estimator
#: and the tree predictors of its HistGradientBoostingRegressors).
TRUSTED = ("terrain.slip.learned.SlipRegressor",
           "sklearn.ensemble._hist_gradient_boosting.predictor.TreePredictor")
#: the files the command writes to --out (an earlier run's that this one lacks are removed)
OUTPUTS = ("std_calibration.csv", "summary.json", "slip_errors.csv", "odometry.csv",
           "slip_errors.png", "odometry.png", "measured_checks.csv")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain slip-fit``: terrains, scenarios, training and held-out test
    seeds, ``--duration-s`` (simulated time per run, s), ``--orchard-duration-s`` (held-out
    orchard runs for the odometry, s), ``--cache-dir``, ``--out``,
    ``--no-loto``, ``--measured`` dataset and ``--no-register``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    parser.add_argument("--terrains", nargs="+", type=terrain_name, action=DistinctValues,
                        default=list(TERRAIN_NAMES))
    parser.add_argument("--scenarios", nargs="+",
                        default=["straight_accel", "orchard", "slope_turn", "random"])
    parser.add_argument("--train-seeds", nargs="+", type=seed_value, action=DistinctSeeds,
                        default=[0, 1])
    parser.add_argument("--test-seeds", nargs="+", type=seed_value, action=DistinctSeeds,
                        default=[100])
    parser.add_argument("--duration-s", type=float, default=40.0)
    parser.add_argument("--orchard-duration-s", type=float, default=120.0,
                        help="held-out orchard runs of this length for the odometry (a 40 s "
                             "run ends before the first headland turn); <= --duration-s: none")
    parser.add_argument("--cache-dir", type=output_dir, default=Path("out/slip_cache"),
                        help="simulated runs, one file per run, keyed by its settings and by "
                             "the simulator's parameters and code (a run cached by an "
                             "earlier simulator is simulated again and replaced)")
    parser.add_argument("--out", type=output_dir, default=Path("out/slip_fit"))
    parser.add_argument("--no-loto", action="store_true", help="skip leave-one-terrain-out")
    parser.add_argument("--measured", default=None, choices=list(DATASET_SPECS),
                        help="also check the model on a shipped measured dataset (borealtc)")
    parser.add_argument("--no-register", action="store_true",
                        help=f"log the model without registering it as {REGISTERED_SLIP_MODEL}")


def main(args: argparse.Namespace) -> int:
    """Simulate (cached), fit, evaluate, log and register.

    Fits :class:`terrain.slip.learned.SlipRegressor` on the Husky runs of the training seeds,
    calibrates its slip std on grouped out-of-fold residuals of the training runs (held-out
    coverage in ``std_calibration.csv``), compares it with the baselines on the held-out seeds
    (median absolute slip error, steady straight and all windows), leave-one-scenario-out and
    (unless ``args.no_loto``) leave-one-terrain-out (without and with the physics features),
    and the odometry error with and without slip compensation (% of distance; plus held-out
    orchard runs of ``args.orchard_duration_s``); writes tables, ``summary.json`` and figures
    to ``args.out``, logs them to the MLflow experiment ``terrain-slip-fit`` and registers the
    model as ``slip-husky`` unless ``args.no_register``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        Exit status, 0.

    Raises
    ------
    ConfigError
        A seed in both ``--train-seeds`` and ``--test-seeds``, an unknown scenario (an
        unknown terrain is a usage error of ``--terrains``, any case), a ``--duration-s``
        shorter than one slip window (:data:`features.slip_features.SLIP_WINDOW`, 2 s), or
        a duration (``--duration-s``, or an ``--orchard-duration-s`` longer than it or NaN)
        the simulation refuses; checked before any run is simulated.
    DataFormatError
        The ``--measured`` dataset cannot be read (read before any run is simulated).
    """
    from threadpoolctl import threadpool_limits
    both = sorted(set(args.train_seeds) & set(args.test_seeds))
    if both:  # a seed in both would be scored as held out and silently left out of training
        raise ConfigError(f"seed(s) {both} in both --train-seeds and --test-seeds: the held-out "
                          "runs are those of seeds the model was not fitted on")
    if not args.duration_s >= SLIP_WINDOW.window_s:  # runs without a window: nothing to fit
        raise ConfigError(f"--duration-s must be at least one slip window "
                          f"({SLIP_WINDOW.window_s:g} s), got {args.duration_s:g}")
    _simulation_takes("--duration-s", args.duration_s)
    if not args.orchard_duration_s <= args.duration_s:  # NaN, or an orchard run to simulate
        _simulation_takes("--orchard-duration-s", args.orchard_duration_s)
    # a --measured dataset that cannot be read fails here, not after hours of fitting
    measured = load_dataset(args.measured) if args.measured else None
    vehicle = get_vehicle("husky")
    spec = SlipDataSpec(tuple(args.terrains), tuple(args.scenarios),
                        tuple(args.train_seeds) + tuple(args.test_seeds), args.duration_s)
    runs = simulated_runs(spec, args.cache_dir)
    X, Yf, meta = slip_table(runs, vehicle, TERRAIN_NAMES)
    Y = Yf[list(SLIP_OUTPUTS)].to_numpy()
    test = meta["seed"].isin(args.test_seeds).to_numpy()
    train = ~test
    steady = steady_straight(meta, Yf["yaw_rate"].to_numpy())
    params = {"n_runs": len(runs), "n_windows": len(X), **{k: str(v) for k, v in option_params(
        args, ("out", "cache_dir")).items()}}
    # every output written in a staging folder and moved into --out once all are: a failure
    # leaves the earlier run's files whole, not a new summary.json beside its tables
    with threadpool_limits(1, "openmp"), tracked_run(EXPERIMENT, "slip-husky", params) as run, \
            staged_outputs(args.out, OUTPUTS) as stage:
        model = SlipRegressor().fit(X[train], Y[train],
                                    groups=meta["run_id"].to_numpy()[train])
        preds = {"learned": model.predict(X)}
        calib = pd.concat([std_calibration_table(preds["learned"], model.predict_std(X), Y,
                                                 meta, m, by).assign(windows=name)
                           for name, m, by in (("all", test, ("scenario",)),
                                               ("steady_straight", steady & test, ("terrain",)))],
                          ignore_index=True)
        calib.to_csv(stage / "std_calibration.csv", index=False)
        run.log_table(calib, "std_calibration.csv")
        run.log_metrics({f"calibration.train_oof.{k}": v for k, v in model.calibration_.items()})
        preds.update(baseline_predictions(X, Y, meta, train, runs, vehicle.track_m))
        tables = []
        for name, p in preds.items():
            for cond, mask in (("steady_straight", steady & test), ("all", test)):
                t = error_table(p, Y, meta, mask)
                tables.append(t.assign(model=name, windows=cond, split="held-out seeds"))
        loso = leave_one_out(SlipRegressor, X, Y, meta["scenario"].to_numpy(), train, test)
        tables.append(error_table(loso, Y, meta, test, ("scenario",)).assign(
            model="learned", windows="all", split="leave-one-scenario-out"))
        # leave-one-terrain-out: no terrain knowledge (probabilities and physics dropped), and
        # with the physics slip kept (the unseen ground's catalogue curve known, no data)
        for split, drop in ((("leave-one-terrain-out", terrain_columns(X.columns)),
                             ("leave-one-terrain-out-physics",
                              [c for c in X.columns if c.startswith("p__")]))
                            if not args.no_loto else ()):
            loto = leave_one_out(SlipRegressor, X.drop(columns=drop), Y,
                                 meta["terrain"].to_numpy(), train, test)
            for cond, mask in (("steady_straight", steady & test), ("all", test)):
                tables.append(error_table(loto, Y, meta, mask).assign(
                    model="learned", windows=cond, split=split))
        errors = pd.concat(tables, ignore_index=True)
        odo_runs = meta.loc[test & meta["scenario"].isin(["orchard", "slope_turn"]).to_numpy(),
                            "run_id"].unique()
        odo = odometry_errors(runs, meta, preds["learned"], vehicle.track_m, odo_runs)
        truth_in = np.where(np.isnan(Y), 1.0, Y)        # chi = 1 where the robot does not turn
        odo["oracle_err_pct"] = odometry_errors(runs, meta, truth_in, vehicle.track_m,
                                                odo_runs)["compensated_err_pct"]
        if args.orchard_duration_s > args.duration_s:
            odo = pd.concat([odo, _long_orchard(args, vehicle, model)], ignore_index=True)
        summary = _summary(errors, odo)
        (stage / "summary.json").write_text(strict_json(summary, indent=2))
        run.log_metrics(summary)
        for frame, name in ((errors, "slip_errors.csv"), (odo, "odometry.csv")):
            frame.to_csv(stage / name, index=False)
            run.log_table(frame, name)
        for name, fig in (("slip_errors.png", error_figure(errors, TARGET_TERRAINS)),
                          ("odometry.png", odometry_figure(odo))):
            fig.savefig(stage / name, dpi=110)
            run.log_figure(fig, name)
        if measured is not None:
            checks = _measured(measured, model, vehicle)
            checks.to_csv(stage / "measured_checks.csv", index=False)
            run.log_table(checks, "measured_checks.csv")
            print(checks.round(4).to_string(index=False))
        uri = run.log_sklearn_model(model, "slip-model", X.iloc[:5],
                                    None if args.no_register else REGISTERED_SLIP_MODEL, TRUSTED)
    steady_errors = errors[(errors.windows == "steady_straight")
                           & errors.terrain.isin(TARGET_TERRAINS)]
    if len(steady_errors):
        print(steady_errors.pivot_table(index="terrain", columns=["split", "model"],
                                        values="median_abs_err").round(4).to_string())
    else:   # short runs or other terrains: the tables in --out hold what was scored
        print(f"note: no steady straight window of {', '.join(TARGET_TERRAINS)} in the held-out "
              f"runs: no median slip error table to print (slip_errors.csv holds "
              f"{len(errors)} row(s))")
    print(strict_json(summary).rstrip() if summary else "note: summary.json is empty (no "
          "steady straight window of those terrains, no orchard or slope_turn run held out)")
    print(f"logged model: {uri}; tables in {args.out}")
    print(run.describe())
    return 0


def _simulation_takes(option: str, duration_s: float) -> None:
    """Refuse a duration the simulation refuses (SimConfig: at most 7200 s), named as the
    option, before hours of simulating and fitting."""
    try:
        next(SlipDataSpec(("ASPHALT",), ("orchard",), (0,), duration_s).configs())
    except ConfigError as exc:
        raise ConfigError(f"{option}: {exc}") from None


def _long_orchard(args: argparse.Namespace, vehicle, model: SlipRegressor) -> pd.DataFrame:
    spec = SlipDataSpec(tuple(args.terrains), ("orchard",), tuple(args.test_seeds),
                        args.orchard_duration_s)
    runs = simulated_runs(spec, args.cache_dir)
    X, Yf, meta = slip_table(runs, vehicle, TERRAIN_NAMES)
    Y = Yf[list(SLIP_OUTPUTS)].to_numpy()
    ids = meta["run_id"].unique()
    odo = odometry_errors(runs, meta, model.predict(X), vehicle.track_m, ids)
    odo["oracle_err_pct"] = odometry_errors(runs, meta, np.where(np.isnan(Y), 1.0, Y),
                                            vehicle.track_m, ids)["compensated_err_pct"]
    return odo.assign(scenario=f"orchard_{args.orchard_duration_s:g}s")


def _measured(runs: list, model: SlipRegressor, vehicle) -> pd.DataFrame:
    ws = slip_windows(runs)
    X = slip_features(ws, vehicle, one_hot_probabilities(ws.labels.astype(str), TERRAIN_NAMES))
    return measured_checks(X, model.predict(X), ws.run_ids, ws.labels.astype(str),
                           vehicle.track_m)


def _summary(errors: pd.DataFrame, odo: pd.DataFrame) -> dict[str, float]:
    out = {}
    sel = errors[(errors.windows == "steady_straight") & errors.terrain.isin(TARGET_TERRAINS)]
    for (split, model, terr), v in sel.set_index(["split", "model", "terrain"])[
            "median_abs_err"].items():
        out[f"{split.replace(' ', '_')}.{model}.{terr}.median_abs_err"] = float(v)
    for scen, every in odo.groupby("scenario"):
        # a run that slid off its slope is left out of the medians: counted, not dropped
        # unseen (a scenario whose every run slid off kept no key at all)
        slid = every["slid_off"].astype(bool)
        out[f"odometry.{scen}.slid_off_runs"] = float(slid.sum())
        g = every[~slid]
        plain, comp = float(g["plain_err_pct"].median()), float(g["compensated_err_pct"].median())
        out[f"odometry.{scen}.plain_err_pct"] = plain
        out[f"odometry.{scen}.compensated_err_pct"] = comp
        # plain odometry exactly on the truth: no reduction (NaN, as odometry_errors' own
        # reduction_pct), not a ZeroDivisionError after the whole fit
        reduction = (lambda err: 100 * (1 - err / plain) if plain > 0 else float("nan"))
        out[f"odometry.{scen}.reduction_of_median_pct"] = reduction(comp)
        gyro = float(g["compensated_gyro_err_pct"].median())
        out[f"odometry.{scen}.compensated_gyro_err_pct"] = gyro
        out[f"odometry.{scen}.gyro_heading_err_pct"] = float(g["gyro_heading_err_pct"].median())
        out[f"odometry.{scen}.gyro_reduction_of_median_pct"] = reduction(gyro)
        slipping = g[g["plain_err_pct"] > 2.0]       # beyond the 0.8 % speed-quantum floor
        out[f"odometry.{scen}.slipping_runs"] = float(len(slipping))
        out[f"odometry.{scen}.slipping_median_reduction_pct"] = float(
            slipping["reduction_pct"].median()) if len(slipping) else float("nan")
    return out
