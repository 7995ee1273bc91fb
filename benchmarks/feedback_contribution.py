"""What the traction controller's feedback adds to its feed-forward slip limit (measured).

The traction loop (:class:`terrain.control.closed_loop.TractionLoop`) corrects each wheel
with a one-sided PI on the estimated slip and, on a catalogued terrain, with the
feed-forward limit of :mod:`terrain.control.feedforward`. This script runs the closed loop
with the feedback's gains at zero (feed-forward alone), at the vehicle's
:data:`~terrain.control.closed_loop.DEFAULT_GAINS` and at ``--strong-kp`` (ki 0), each
vehicle with its default estimator, over terrains x scenarios x seeds (the label as terrain
decision), and prints per vehicle, scenario and terrain the mean true slip RMSE and peak
slip of each setting with the controller off as reference, and the share of runs where the
default gains change the slip RMSE by more than 1e-4. Logged to MLflow (experiment
``terrain-benchmark``, run ``feedback-contribution``) with the per-run CSV.

``--decided PLANT=LABEL ...`` runs, instead of ``--terrains``, each plant terrain with the
loop told it drives on LABEL (target, feed-forward curve and the estimator's slip model of
LABEL): a ground off the curve the controller assumes, the case the feedback is for (MLflow
run ``feedback-contribution-decided``).

Run: ``python benchmarks/feedback_contribution.py [--vehicles agrimaro husky] [--terrains
TILES GRASS UNPLOUGHED SANDY_LOAM SNOW ICE] [--scenarios straight_accel orchard slope_turn]
[--seeds 0 1 2] [--duration-s 20] [--strong-kp 20] [--decided ICE=TILES ...] [--out DIR]
[--no-mlflow]`` (about 6 min on 2 cores for the default grid).
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import pandas as pd
from tqdm import tqdm

from pipelines.arguments import (DistinctSeeds, DistinctValues, output_dir, positive_number,
                                 seed_value, sim_duration_s)
from terrain.control.closed_loop import LOOP_SETTINGS, default_gains, run_closed_loop
from terrain.control.desired_slip import build_slip_table
from terrain.errors import ConfigError
from terrain.terramechanics import get_terrain
from terrain.sim import SCENARIO_NAMES
from terrain.tracking import require_store, tracked_run

#: metrics of :func:`terrain.control.closed_loop.loop_metrics` kept per run
KEPT = ("slip_rmse", "peak_slip", "time_to_speed_s", "energy_j_per_m")


def settings(vehicle: str, strong_kp: float) -> dict[str, tuple[bool, tuple[float, float]]]:
    """The loop settings compared: name -> (controller applied, (kp, ki)).

    Parameters
    ----------
    vehicle : str
        ``agrimaro`` or ``husky``.
    strong_kp : float
        Proportional gain of the ``strong`` setting, rad/s per unit slip (ki 0).

    Returns
    -------
    dict
        ``off`` (shadow mode), ``ff_only`` (feed-forward, feedback gains 0), ``default``
        (:func:`~terrain.control.closed_loop.default_gains`), ``strong``.
    """
    return {"off": (False, default_gains(vehicle)), "ff_only": (True, (0.0, 0.0)),
            "default": (True, default_gains(vehicle)), "strong": (True, (strong_kp, 0.0))}


def decided_labels(pairs: list[str]) -> list[tuple[str, str]]:
    """``PLANT=LABEL`` arguments as (plant terrain, terrain the loop is told) pairs.

    Parameters
    ----------
    pairs : list of str
        ``PLANT=LABEL`` items (catalogue terrain names, any case).

    Returns
    -------
    list of (str, str)
        Upper-case (plant, label) pairs, in the order given.

    Raises
    ------
    ConfigError
        An item without ``=`` or a pair given twice.
    """
    out: list[tuple[str, str]] = []
    for item in pairs:
        plant, sep, label = item.partition("=")
        if not sep or not plant or not label:
            raise ConfigError(f"--decided takes PLANT=LABEL items, got {item!r}")
        pair = (plant.upper(), label.upper())
        if pair in out:
            raise ConfigError(f"--decided: {pair[0]}={pair[1]} given twice")
        out.append(pair)
    return out


def main() -> int:
    """Run the grid, print the table, log it; returns 0."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", nargs="+", action=DistinctValues, choices=list(LOOP_SETTINGS),
                        default=["agrimaro", "husky"])
    parser.add_argument("--terrains", nargs="+", action=DistinctValues,
                        default=["TILES", "GRASS", "UNPLOUGHED", "SANDY_LOAM", "SNOW", "ICE"])
    parser.add_argument("--scenarios", nargs="+", action=DistinctValues, choices=SCENARIO_NAMES,
                        default=["straight_accel", "orchard", "slope_turn"])
    parser.add_argument("--seeds", nargs="+", type=seed_value, action=DistinctSeeds,
                        default=[0, 1, 2])
    parser.add_argument("--duration-s", type=sim_duration_s, default=20.0)
    parser.add_argument("--strong-kp", type=positive_number, default=20.0)
    parser.add_argument("--decided", nargs="+", action=DistinctValues,
                        default=[], metavar="PLANT=LABEL")
    parser.add_argument("--out", type=output_dir, default=Path("out/feedback_contribution"))
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    try:
        decided = decided_labels(args.decided) or [(t, t) for t in args.terrains]
        for name in {t for pair in decided for t in pair}:
            get_terrain(name)               # an unknown name fails before any run
    except ConfigError as exc:
        parser.error(str(exc))
    cells = list(itertools.product(args.vehicles, args.scenarios, decided, args.seeds))
    rows = []
    for vehicle, scenario, pair, seed in tqdm(cells, desc="closed loops", unit="cell"):
        terrain, label = pair
        for name, (apply, gains) in settings(vehicle, args.strong_kp).items():
            m = run_closed_loop(vehicle, terrain, scenario, apply, seed, args.duration_s, gains,
                                table=build_slip_table(sorted({terrain, label})),
                                terrain_decision=lambda t_s, lab=label: (lab, 1.0))[2]
            rows.append({"vehicle": vehicle, "scenario": scenario,
                         "terrain": terrain if label == terrain else f"{terrain}={label}",
                         "seed": seed, "setting": name, "kp": gains[0], "ki": gains[1],
                         **{k: m[k] for k in KEPT}})
    runs = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    runs.to_csv(args.out / "runs.csv", index=False)
    keys = ["vehicle", "scenario", "terrain"]
    wide = runs.pivot_table(index=keys + ["seed"], columns="setting",
                            values=["slip_rmse", "peak_slip"])
    changed = ((wide["slip_rmse", "default"] - wide["slip_rmse", "ff_only"]).abs() > 1e-4)
    table = wide.groupby(level=keys).mean()
    table.columns = [f"{metric}_{setting}" for metric, setting in table.columns]
    table["default_changes_rmse"] = changed.groupby(level=keys).mean()
    table = table.reset_index()
    table.to_csv(args.out / "table.csv", index=False)
    cols = keys + [f"slip_rmse_{s}" for s in ("off", "ff_only", "default", "strong")] + [
        f"peak_slip_{s}" for s in ("off", "ff_only", "default", "strong")] + [
        "default_changes_rmse"]
    with pd.option_context("display.width", 250, "display.max_rows", 500):
        print(table[cols].round(4).to_string(index=False))
    metrics = {}
    for vehicle, g in table.groupby("vehicle"):
        gains = default_gains(vehicle)
        print(f"{vehicle} (default gains kp {gains[0]:g}, ki {gains[1]:g}): the default "
              f"gains change the slip RMSE of {g['default_changes_rmse'].mean():.0%} of the runs;"
              f" mean slip RMSE off {g['slip_rmse_off'].mean():.4f}, feed-forward only "
              f"{g['slip_rmse_ff_only'].mean():.4f}, default {g['slip_rmse_default'].mean():.4f},"
              f" kp {args.strong_kp:g} {g['slip_rmse_strong'].mean():.4f}")
        for s in ("off", "ff_only", "default", "strong"):
            metrics[f"{vehicle}_slip_rmse_{s}"] = float(g[f"slip_rmse_{s}"].mean())
        metrics[f"{vehicle}_default_changes_rmse"] = float(g["default_changes_rmse"].mean())
    if not args.no_mlflow:
        params = {"vehicles": " ".join(args.vehicles),
                  "terrains": " ".join(f"{p}={lab}" for p, lab in decided),
                  "scenarios": " ".join(args.scenarios),
                  "seeds": " ".join(map(str, args.seeds)), "duration_s": args.duration_s,
                  "strong_kp": args.strong_kp}
        name = "feedback-contribution" + ("-decided" if args.decided else "")
        with tracked_run("terrain-benchmark", run_name=name, params=params) as run:
            run.log_metrics(metrics)
            run.log_artifact(str(args.out / "runs.csv"))
            run.log_artifact(str(args.out / "table.csv"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
