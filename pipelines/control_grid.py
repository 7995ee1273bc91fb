"""Closed-loop validation grid of the traction controller: tune, run, tabulate (MLflow-tracked).

Tunes the traction gains on tuning seeds, then runs vehicles x terrains x scenarios x
controller off/on x evaluation seeds; writes a table, plots and the quasi-static slip-limit
bound, and logs everything to MLflow (experiment terrain-control).

Default (small, about a minute on a loaded core): both vehicles, TILES GRASS SANDY_LOAM SNOW
ICE, straight_accel, seed 0, 20 s. Full grid (docs/control_validation.md):
  terrain control-grid --scenarios straight_accel orchard slope_turn --seeds 0 1 2 --out OUT
--no-tune uses terrain.control.closed_loop.default_gains (per vehicle and estimator) instead of
tuning. --terrain-source live-sim takes the terrain decisions from the live classifier trained
on simulated runs of each vehicle on the --classifier-seeds (pipelines/control_classifier.py),
run on each closed loop's own sensor samples (pipelines/live_terrain.py; the gain tuning keeps
the label); the default is the run's label. The live-sim classifier's training runs include
closed-loop runs with the traction controller on (the grid's gains, estimator and
feed-forward, the label as terrain decision); --classifier-uncontrolled-only trains it on
uncontrolled runs only (the earlier classifier).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipelines.arguments import (DistinctSeeds, model_folder, non_negative_number,
                                 option_params, output_dir, seed_value, sim_duration_s)
from pipelines.control_classifier import (CLASSIFIER_SEEDS, TERRAIN_SOURCES,
                                          add_classifier_options, check_classifier_seeds,
                                          check_decision_options, decision_source)
from pipelines.control_sim import SCENARIOS, check_duration
from terrain.control.closed_loop import default_gains
from terrain.control.estimators import ESTIMATORS
from terrain.control.grid import (TUNING_SEEDS, check_grid_axes, compare, markdown_table,
                                  run_grid, slip_limit_bound, tune_gains)
from terrain.control.traction import TractionControlConfig
from terrain.errors import ConfigError, duplicated
from terrain.io.jsonfile import staged_outputs, strict_json
from terrain.terramechanics.catalogue import get_terrain
from terrain.tracking import tracked_run

#: the files the command writes to --out (an earlier run's that this one lacks are removed)
OUTPUTS = ("runs.csv", "comparison.csv", "comparison.md", "summary.json", "tuning_*.csv",
           "slip_*.png", "energy_per_m.png")

EXPERIMENT = "terrain-control"
SOFT = ("GRASS", "UNPLOUGHED", "SANDY_LOAM", "SNOW")
#: Default tuning grids: proportional gain, rad/s per unit slip; integral gain, rad/s per
#: unit slip and s.
KP_GRID = (2.0, 5.0, 10.0, 20.0)
KI_GRID = (0.0, 10.0)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain control-grid``: vehicles, terrains, scenarios, evaluation seeds,
    ``--duration-s`` (simulated time per run, s), ``--no-tune``, the proportional
    (rad/s per unit slip) and integral (rad/s per unit slip and s) gain grids,
    ``--husky-estimator``, ``--agrimaro-estimator``, ``--no-feed-forward``, the
    ``--terrain-source`` (with ``--model`` or the live-sim ``--classifier-seeds`` and
    ``--classifier-uncontrolled-only``) and ``--out``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    # any case, as terrain simulate and the vehicle catalogue read it
    parser.add_argument("--vehicles", nargs="+", type=str.lower,
                        default=["agrimaro", "husky"])
    parser.add_argument("--terrains", nargs="+",
                        default=["TILES", "GRASS", "SANDY_LOAM", "SNOW", "ICE"])
    parser.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=["straight_accel"])
    parser.add_argument("--seeds", nargs="+", type=seed_value, action=DistinctSeeds,
                        default=[0])
    parser.add_argument("--duration-s", type=sim_duration_s, default=20.0)
    parser.add_argument("--no-tune", action="store_true", help="use the default gains")
    parser.add_argument("--kp-grid", nargs="+", type=non_negative_number, default=list(KP_GRID))
    parser.add_argument("--ki-grid", nargs="+", type=non_negative_number, default=list(KI_GRID))
    parser.add_argument("--husky-estimator", choices=ESTIMATORS["husky"],
                        default=ESTIMATORS["husky"][0],
                        help="the Husky's slip estimator (default: the fused slip estimate)")
    parser.add_argument("--agrimaro-estimator", choices=ESTIMATORS["agrimaro"],
                        default=ESTIMATORS["agrimaro"][0],
                        help="the AgriMaRo's slip estimator (default: its EKF with visual "
                             "odometry on the gyro of the full IMU a robot logs; ekf-vo on "
                             "the loop's simplified IMU without vibration and gravity)")
    parser.add_argument("--no-feed-forward", action="store_true",
                        help="feedback only (no feed-forward slip limit)")
    parser.add_argument("--terrain-source", choices=TERRAIN_SOURCES, default="label",
                        help="terrain decisions: label (default), live-sim (classifier "
                             "trained on simulated runs) or model (--model)")
    parser.add_argument("--model", type=model_folder, default=None,
                        help="classifier of --terrain-source model")
    add_classifier_options(parser)
    parser.add_argument("--out", type=output_dir, required=True, help="output folder")


def _plots(traces: dict, table, out: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    paths = []
    for (veh, ter, sc, ctrl, seed), tr in traces.items():
        if ctrl != "traction" or sc != "straight_accel" or seed != min(k[4] for k in traces):
            continue
        off = traces[veh, ter, sc, "off", seed]
        fig, ax = plt.subplots(figsize=(7, 3))
        try:    # closed also when the write fails: pyplot would hold it open
            ax.plot(off["t_s"], off["slip_true_1"], label="true slip, off", lw=0.8)
            ax.plot(tr["t_s"], tr["slip_true_1"], label="true slip, traction", lw=0.8)
            ax.plot(tr["t_s"], tr["target_1"], "k--", label="target", lw=0.8)
            ax.set(xlabel="t (s)", ylabel="slip, unit 1",
                   title=f"{veh} {ter} {sc} seed {seed}")
            ax.legend(fontsize=7)
            paths.append(out / f"slip_{veh}_{ter}_{sc}.png")
            fig.savefig(paths[-1], dpi=90, bbox_inches="tight")
        finally:
            plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 3))
    try:
        lab = table["vehicle"] + "\n" + table["terrain"] + "\n" + table["scenario"].str[:8]
        x = range(len(table))
        ax.bar([i - 0.2 for i in x], table["energy_off"], 0.4, label="off")
        ax.bar([i + 0.2 for i in x], table["energy_on"], 0.4, label="traction")
        ax.set_xticks(list(x), lab, fontsize=6)
        ax.set(ylabel="energy (J/m)")
        ax.legend()
        paths.append(out / "energy_per_m.png")
        fig.savefig(paths[-1], dpi=90, bbox_inches="tight")
    finally:
        plt.close(fig)
    return paths


def check_grid(args: argparse.Namespace) -> None:
    """Refuse, before any tuning run, an axis value the grid would fail on hours later.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Raises
    ------
    ConfigError
        An unknown vehicle or terrain, a ``--duration-s`` :class:`terrain.sim.SimConfig`
        refuses (:func:`pipelines.control_sim.check_duration`), a gain of the grids
        :class:`terrain.control.traction.TractionControlConfig` refuses (negative or not
        finite; their argparse type refuses them first, naming the option), an evaluation
        seed that is a tuning seed, a value repeated on an axis or in a gain grid, a
        live-sim classifier seed that is an evaluation or tuning seed
        (:func:`pipelines.control_classifier.check_classifier_seeds`), a
        terrain-source option the source
        would ignore (:func:`pipelines.control_classifier.check_decision_options`), gain
        grids other than the default with ``--no-tune``, or a ``--husky-estimator`` or
        ``--agrimaro-estimator`` other than the default with no such vehicle in
        ``--vehicles`` (both would be ignored, and logged to MLflow as if used).
    """
    for vehicle in args.vehicles:
        default_gains(vehicle)
        for terrain in args.terrains:
            get_terrain(terrain)
            for scenario in args.scenarios:
                for seed in args.seeds:
                    check_duration(vehicle, terrain, scenario, args.duration_s, seed)
    for kp in args.kp_grid:
        for ki in args.ki_grid:
            TractionControlConfig(kp=kp, ki=ki)
    shared = sorted(set(args.seeds) & set(TUNING_SEEDS))
    if shared:
        raise ConfigError(f"evaluation seeds {shared} are tuning seeds {list(TUNING_SEEDS)}: "
                          "choose others")
    check_grid_axes(args.vehicles, args.terrains, args.scenarios, args.seeds)
    check_decision_options(args.terrain_source, args.model, args.classifier_seeds,
                           args.classifier_uncontrolled_only)
    if args.terrain_source == "live-sim":   # the classifier is trained after the tuning
        check_classifier_seeds(args.classifier_seeds or CLASSIFIER_SEEDS, args.seeds)
    for option, values in (("--kp-grid", args.kp_grid), ("--ki-grid", args.ki_grid)):
        repeated = duplicated(values)
        if repeated:
            raise ConfigError(f"{option}: {repeated} given more than once (each gain once)")
    grids = [option for option, values, default in (("--kp-grid", args.kp_grid, KP_GRID),
                                                    ("--ki-grid", args.ki_grid, KI_GRID))
             if tuple(values) != default]
    if args.no_tune and grids:
        raise ConfigError(f"{' and '.join(grids)} {'are' if len(grids) > 1 else 'is a'} "
                          f"tuning grid{'s' if len(grids) > 1 else ''}; --no-tune uses the "
                          f"default gains: leave {'them' if len(grids) > 1 else 'it'} or "
                          "--no-tune out")
    for vehicle, name in (("husky", "Husky"), ("agrimaro", "AgriMaRo")):
        if vehicle not in args.vehicles and (getattr(args, f"{vehicle}_estimator")
                                             != ESTIMATORS[vehicle][0]):
            raise ConfigError(f"--{vehicle}-estimator is the {name}'s slip estimator; "
                              f"--vehicles {' '.join(args.vehicles)} has no {vehicle}: "
                              "leave it out")


def main(args: argparse.Namespace) -> int:
    """Tune, run the grid, write table/plots/JSON, log to MLflow.

    Unless ``args.no_tune``, tunes each vehicle's gains on ICE over the tuning seeds
    (:func:`terrain.control.grid.tune_gains`); then runs the grid with the controller off and
    on and writes ``runs.csv``, ``comparison.csv``/``.md``, ``tuning_<vehicle>.csv``,
    ``summary.json`` (gains, comparison, quasi-static slip-limit bound) and plots to
    ``args.out``, all logged to the MLflow experiment ``terrain-control``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        Exit status, 0.
    """
    # the catalogue reads terrain names in any case; the tables, plots and the soft-terrain
    # slip-limit bound (SOFT) compare them in upper case (in a copy: the caller's Namespace
    # is left as it was)
    args = argparse.Namespace(**{**vars(args),
                                 "terrains": [str(t).upper() for t in args.terrains]})
    check_grid(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    params = option_params(args)
    # every output written in a staging folder and moved into --out once all are: a failure
    # leaves the earlier run's files whole, not a new summary.json beside its plots
    with tracked_run(EXPERIMENT, run_name="control-grid", params=params) as run, \
            staged_outputs(out, OUTPUTS) as stage:
        estimators = {"husky": args.husky_estimator, "agrimaro": args.agrimaro_estimator}
        gains = {v: default_gains(v, estimators.get(v)) for v in args.vehicles}
        tuning = {}
        if not args.no_tune:
            for veh in args.vehicles:
                step = iter(range(10_000))
                gains[veh], tuning[veh] = tune_gains(
                    veh, ["ICE"], args.kp_grid, args.ki_grid,
                    log=lambda r, v=veh: run.log_metrics(
                        {f"tune_{v}_cost": r["cost"]}, step=next(step)),
                    estimator=estimators.get(veh), feed_forward=not args.no_feed_forward)
                tuning[veh].to_csv(stage / f"tuning_{veh}.csv", index=False)
                run.log_table(tuning[veh], f"tuning_{veh}.csv")
        decisions, classifiers = {}, {}
        for veh in args.vehicles:
            decisions[veh], classifiers[veh] = decision_source(
                args.terrain_source, veh, args.terrains, args.seeds, args.model,
                args.classifier_seeds or CLASSIFIER_SEEDS,
                controlled_runs=not args.classifier_uncontrolled_only,
                gains=gains[veh], estimator=estimators.get(veh),
                feed_forward=not args.no_feed_forward)
            run.log_dict(classifiers[veh], f"classifier_{veh}.json")
        results, traces = run_grid(args.vehicles, args.terrains, args.scenarios, args.seeds,
                                   gains, args.duration_s, estimators,
                                   not args.no_feed_forward, decisions)
        table = compare(results)
        results.to_csv(stage / "runs.csv", index=False)
        table.to_csv(stage / "comparison.csv", index=False, float_format="%.4f")
        (stage / "comparison.md").write_text(markdown_table(table))
        bound = [slip_limit_bound(r.terrain, r.peak_slip_off) for r in table.itertuples()
                 if r.terrain in SOFT and r.scenario == "straight_accel"]
        summary = {"gains": {v: list(g) for v, g in gains.items()},
                   "tuning_seeds": list(TUNING_SEEDS), "evaluation_seeds": args.seeds,
                   "comparison": table.to_dict(orient="records"), "slip_limit_bound": bound,
                   "terrain_source": classifiers}
        (stage / "summary.json").write_text(strict_json(summary))
        for p in _plots(traces, table, stage):
            run.log_artifact(p, "plots")
        run.log_table(table, "comparison.csv")
        run.log_dict(summary, "summary.json")
        print(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    return 0
