"""Simulate a vehicle with the traction controller in the loop and score it (JSON).

The simulator (terrain.sim) with the controller of terrain.control called at 50 Hz on the
robot's own sensor samples: the slip comes from the vehicle's estimator (AgriMaRo: the
streaming EKF with the T265 visual odometry; Husky: the fused slip estimate of issue 10 run
online, --estimator observer for the earlier wheel + IMU observer; limits stated in the JSON),
the target from the desired-slip table. --controller off runs the
same loop in shadow mode (no correction), scored against the same targets.

Terrain decisions (--terrain-source): `live-sim` (default without --model) the live
classifier trained on simulated runs of the same vehicle on the
--classifier-seeds, uncontrolled and with the traction controller on (this run's gains,
estimator and feed-forward; --classifier-uncontrolled-only: uncontrolled runs only)
(pipelines/control_classifier.py, cached under out/control_classifier);
`model` (default with --model DIR, a model saved by `terrain train --model-out DIR`) that
classifier; `label` the run's ground-truth label (the controller measured without
classification errors, as `terrain control-grid` does by default). A classifier runs live on the
loop's own sensor samples, causally (pipelines/live_terrain.py), where the model applies (trained on
the vehicle's data, the run's terrain among its classes); otherwise the label is used, with the
reason in the JSON (terrain_source).

JSON fields: slip_rmse, peak_slip, time_to_speed_s, energy_j_per_m (V_bus x motor currents),
distance_m, mean_speed_m_s, terrain_accuracy, speed_limit_clipped_steps and
correction_clipped_steps (per motor, physics steps whose command, before and after the
controller's correction, was clipped at the wheel speed limit; a note says so when any was),
controller_cam_rows_dropped (AgriMaRo: camera samples the controller's own camera outages
removed) and more (terrain.control.closed_loop.loop_metrics).
"""

from __future__ import annotations

import argparse

from pipelines.arguments import (model_folder, non_negative_number, output_file, seed_value,
                                 sim_duration_s)
from pipelines.control_classifier import (CLASSIFIER_SEEDS, TERRAIN_SOURCES,
                                          add_classifier_options, check_decision_options,
                                          decision_source)
from terrain.control.closed_loop import default_gains, run_closed_loop, trace_frame
from terrain.control.estimators import ESTIMATORS
from terrain.errors import ConfigError
from terrain.io.jsonfile import replace_text, strict_json
from terrain.sim.simulate import SimConfig
from terrain.terramechanics.catalogue import get_terrain

VEHICLES = ("agrimaro", "husky")
SCENARIOS = ("straight_accel", "orchard", "slope_turn")
TERRAIN_SOURCE_NOTE = ("label: terrain decisions are the run's ground-truth label (confidence "
                       "1), terrain_accuracy is 1 by construction; --terrain-source label "
                       "(live-sim: the classifier trained on simulated runs; model: a "
                       "`terrain train` model where it applies)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain control-sim``: vehicle, terrain, scenario, controller
    (``off`` or ``traction``), seed, ``--duration-s`` (s), gains ``--kp`` (rad/s per unit
    slip) and ``--ki`` (rad/s per unit slip and s), an optional classifier ``--model``, the
    slip ``--estimator``, ``--no-feed-forward``, the live-sim ``--classifier-seeds`` and
    ``--classifier-uncontrolled-only`` and the ``--json`` / ``--csv`` outputs.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    # any case, as terrain simulate and the vehicle catalogue read it
    parser.add_argument("--vehicle", required=True, type=str.lower, choices=VEHICLES)
    parser.add_argument("--terrain", required=True, help="catalogued terrain class")
    parser.add_argument("--scenario", required=True, choices=SCENARIOS)
    parser.add_argument("--controller", required=True, choices=("off", "traction"))
    parser.add_argument("--seed", type=seed_value, default=0, help="run seed")
    parser.add_argument("--duration-s", type=sim_duration_s, default=20.0,
                        help="simulated time, s")
    parser.add_argument("--kp", type=non_negative_number, default=None,
                        help="proportional gain, rad/s per unit slip (default: tuned)")
    parser.add_argument("--ki", type=non_negative_number, default=None,
                        help="integral gain, rad/s per unit slip and s (default: tuned)")
    parser.add_argument("--model", type=model_folder, default=None,
                        help="terrain classifier saved by `terrain train --model-out DIR`")
    parser.add_argument("--terrain-source", choices=TERRAIN_SOURCES, default=None,
                        help="terrain decisions: live-sim (classifier trained on simulated "
                             "runs, run live on the loop's samples; trained once, then "
                             "cached), model (--model) or label (ground truth); default "
                             "model with --model, else live-sim")
    add_classifier_options(parser)
    parser.add_argument("--estimator", default=None,
                        choices=sorted({k for v in ESTIMATORS.values() for k in v}),
                        help="slip estimator (default: the vehicle's: AgriMaRo ekf-vo-full-gyro, "
                             "Husky fused, both on the gyro of the IMU a robot logs)")
    parser.add_argument("--no-feed-forward", action="store_true",
                        help="feedback only (no feed-forward slip limit)")
    parser.add_argument("--json", type=output_file, required=True, help="output JSON file")
    parser.add_argument("--csv", type=output_file, default=None, help="optional per-step trace CSV")


def check_duration(vehicle: str, terrain: str, scenario: str, duration_s: float,
                   seed: int) -> None:
    """Refuse a ``--duration-s`` that :class:`terrain.sim.SimConfig` refuses for this run,
    named as the option (the configuration's message, e.g. the vehicle's minimum, follows).

    Parameters
    ----------
    vehicle, terrain, scenario : str
        The run's vehicle, catalogued terrain (checked before) and scenario (a choice).
    duration_s : float
        ``--duration-s``, simulated time, s (in (0, 7200]: its argparse type).
    seed : int
        The run's seed (checked by its argparse type).

    Raises
    ------
    ConfigError
        ``--duration-s: <SimConfig's message>``: too short for two samples of every stream
        of the vehicle.
    """
    try:
        SimConfig(vehicle=vehicle, terrains=(terrain.upper(),), scenario=scenario,
                  duration_s=duration_s, seed=seed)
    except ConfigError as exc:
        raise ConfigError(f"--duration-s: {exc}") from None


def main(args: argparse.Namespace) -> int:
    """Run one closed-loop simulation and write its metrics.

    Gains not given default to :func:`terrain.control.closed_loop.default_gains` of the
    vehicle and estimator. With ``--terrain-source live-sim`` or ``model`` (default with
    ``args.model``) the controller's terrain comes from the classifier's decisions on the
    loop's own samples (:func:`pipelines.control_classifier.decision_source`; ``live-sim`` is
    the default without a model), with ``label`` the true terrain. Writes the metrics (peak slip,
    energy in J/m, ...) as standard JSON to ``args.json`` (:func:`terrain.io.jsonfile.strict_json`:
    a non-finite figure is ``null``) and, if ``args.csv``, the per-step trace.

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
        Unknown terrain, or a duration that :class:`terrain.sim.SimConfig` refuses
        (:func:`check_duration`), or an ``--estimator`` of the other vehicle, or ``--model``
        with a terrain source other than ``model``, or ``--kp``, ``--ki`` or
        ``--no-feed-forward`` with ``--controller off`` where no controlled classifier
        training run uses them (checked before a classifier is trained).
    """
    get_terrain(args.terrain)         # an unknown terrain fails here, before any training
    # so does a duration out of range (too short for two samples of every stream): the same
    # configuration run_closed_loop simulates
    check_duration(args.vehicle, args.terrain, args.scenario, args.duration_s, args.seed)
    if args.estimator is not None and args.estimator not in ESTIMATORS[args.vehicle]:
        # the loop refused it only after a live-sim classifier was trained (minutes)
        raise ConfigError(f"--estimator {args.estimator!r} is not available for "
                          f"{args.vehicle}; valid: {', '.join(ESTIMATORS[args.vehicle])}")
    kp, ki = default_gains(args.vehicle, args.estimator)
    gains = (kp if args.kp is None else args.kp, ki if args.ki is None else args.ki)
    terrain, live, note, table = args.terrain.upper(), None, TERRAIN_SOURCE_NOTE, None
    source = args.terrain_source or ("model" if args.model else "live-sim")
    check_decision_options(source, args.model, args.classifier_seeds,
                           args.classifier_uncontrolled_only)
    # with the controller off, the gains and the feed-forward act only on the live-sim
    # classifier's controlled training runs; anywhere else they would be ignored unsaid
    controlled_training = source == "live-sim" and not args.classifier_uncontrolled_only
    unused = [name for name, given in (("--kp", args.kp is not None),
                                       ("--ki", args.ki is not None),
                                       ("--no-feed-forward", args.no_feed_forward)) if given]
    if args.controller == "off" and unused and not controlled_training:
        verb = "acts" if len(unused) == 1 else "act"
        raise ConfigError(f"{', '.join(unused)} {verb} on the traction controller, which "
                          f"--controller off does not run (terrain source {source!r}"
                          + (", uncontrolled classifier runs" if source == "live-sim" else "")
                          + "): leave them out")
    provider, info = decision_source(source, args.vehicle, [terrain], [args.seed],
                                     args.model, args.classifier_seeds or CLASSIFIER_SEEDS,
                                     controlled_runs=not args.classifier_uncontrolled_only,
                                     gains=gains, estimator=args.estimator,
                                     feed_forward=not args.no_feed_forward)
    if provider is not None:   # the table covers every class the model may emit
        live, table, note = provider(terrain)
    sim, loop, metrics = run_closed_loop(args.vehicle, terrain, args.scenario,
                                         args.controller == "traction", args.seed,
                                         args.duration_s, gains, table,
                                         estimator=args.estimator,
                                         feed_forward=not args.no_feed_forward,
                                         live_terrain=live)
    out = {"vehicle": args.vehicle, "terrain": args.terrain.upper(),
           "scenario": args.scenario, "controller": args.controller, "seed": args.seed,
           "duration_s": args.duration_s, "terrain_source": note,
           "classifier": info, **metrics}
    # both texts made before either file is written, each replaced in one step, the JSON
    # last: a failure leaves the earlier pair whole, not a new JSON beside an earlier trace
    text = strict_json(out)
    if args.csv:
        replace_text(args.csv, trace_frame(sim, loop).to_csv(index=False, float_format="%.6g"))
    replace_text(args.json, text)
    energy = metrics["energy_j_per_m"]      # None for a run that does not move
    print(f"wrote {args.json}: peak_slip {metrics['peak_slip']:.3f}, energy "
          + ("n/a (the run did not move)" if energy is None else f"{energy:.1f} J/m"))
    clips = {key: metrics[key] for key in ("speed_limit_clipped_steps",
                                           "correction_clipped_steps") if any(metrics[key])}
    if clips:
        print(f"note: wheel commands clipped at the speed limit, physics steps per motor: "
              f"{clips} (the run does not follow the command there)")
    return 0
