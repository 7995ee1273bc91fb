"""Simulate a vehicle on terrain and write the run in the measured-data layout.

Writes DIR/<TERRAIN>/imu_XX.csv, pro_XX.csv, truth_XX.csv (+ steer, cam, omega, cur for
agrimaro) and meta_XX.json. --terrain takes one class or a comma-separated list (the terrain
then changes every --segment-m metres; the folder is MIXED when it names several). Effects:
NAME=VALUE with NAME in icr_expansion, gyro_bias, wheel_lag, turning_resistance,
current_offset, grade_resistance.
"""

from __future__ import annotations

import argparse

import numpy as np

from pipelines.arguments import output_dir, positive_number, seed_value, sim_duration_s
from terrain.io.jsonfile import folder_lock
from terrain.io.writer import free_index, write_run
from terrain.run import Run
from terrain.sim import (PLANTED_EFFECTS, SCENARIO_NAMES, SimConfig, parse_effects,
                         parse_terrain_list, simulate)
from terrain.sim.dynamics import IMPLICIT_MAX_ITERATIONS
from terrain.sim.forces import DEFAULT_PHYSICS, PHYSICS_VERSIONS
from terrain.sim.simulate import MAX_DURATION_S
from terrain.sim.scenarios import physics_steps
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.vehicles import VEHICLE_NAMES, get_vehicle


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain simulate``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    parser.add_argument("--vehicle", required=True, help=f"one of {', '.join(VEHICLE_NAMES)}")
    parser.add_argument("--terrain", required=True,
                        help="terrain class, or comma-separated classes along the path; one "
                             f"of {', '.join(TERRAIN_NAMES)}")
    parser.add_argument("--scenario", default="random", help=f"one of {', '.join(SCENARIO_NAMES)}")
    parser.add_argument("--duration-s", type=sim_duration_s, default=60.0,
                        help=f"simulated time, s (at most {MAX_DURATION_S:g}; at least two "
                             "samples of the slowest stream: husky 0.16, tracked 0.1, "
                             "agrimaro 0.04)")
    parser.add_argument("--seed", type=seed_value, default=0, help="random seed")
    ranges = ", ".join(f"{name} [{e.lower:g}, {e.upper:g}] "
                       f"{'(dimensionless)' if e.unit == '1' else e.unit}"
                       for name, e in PLANTED_EFFECTS.items())
    parser.add_argument("--effect", action="append", default=[], metavar="NAME=VALUE",
                        help=f"plant a named effect (repeatable, each name once): {ranges}; "
                             "terrain.sim.effects says what each does")
    parser.add_argument("--segment-m", type=positive_number, default=None,
                        help=f"distance between terrain changes, m (default "
                             f"{SimConfig.segment_length_m:g}; with several terrains only)")
    parser.add_argument("--physics", choices=list(PHYSICS_VERSIONS), default=DEFAULT_PHYSICS,
                        help="physics version (v2: load transfer, lateral wheel-soil model, "
                             "docs/physics_v2.md)")
    parser.add_argument("--out", type=output_dir, required=True, help="output root folder")


def main(args: argparse.Namespace) -> int:
    """Run the simulation and write the files.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        0.

    Raises
    ------
    ConfigError
        Unknown vehicle, terrain, scenario or effect, an empty name in the terrain list, a
        repeated effect, or out-of-range settings (a duration too short for two samples of
        every stream); the terrain folder already holds runs 00-99 (checked before
        simulating).
    """
    terrains = parse_terrain_list(args.terrain)
    segment = {} if args.segment_m is None else {"segment_length_m": args.segment_m}
    config = SimConfig(vehicle=args.vehicle.lower(), terrains=terrains,
                       scenario=args.scenario, duration_s=args.duration_s, seed=args.seed,
                       effects=parse_effects(args.effect), physics=args.physics, **segment)
    free_index(args.out / config.run_terrain)   # a full folder refused before simulating
    run = simulate(config)
    folder = args.out / config.run_terrain
    folder.mkdir(parents=True, exist_ok=True)
    # one command at a time takes the next run number and writes it: two at once both took
    # run 00 and wrote it through the same temporary names (one run lost, or an error)
    with folder_lock(folder):
        paths = write_run(run, args.out)
    print(f"wrote {len(paths)} files to {paths['meta'].parent} (run {paths['meta'].stem[-2:]})")
    if segment and len(set(terrains)) == 1:
        # an option that changes nothing is said, not silently ignored
        print(f"note: --segment-m {args.segment_m:g} not used: one terrain ({terrains[0]}) "
              "along the whole path")
    for note in (unreached_terrains_note(run, config), clipped_commands_note(run),
                 unconverged_steps_note(run)):
        if note:
            print(note)
    return 0


def clipped_commands_note(run: Run) -> str | None:
    """A note counting the physics steps whose wheel commands were clipped at the speed limit.

    A scenario's twist may ask a motor for more than its speed limit (the ``random``
    scenario's outer side in a fast turn); the simulator clips each motor's command there
    (:func:`terrain.sim.dynamics.wheel_commands`), so the run does not follow the command.

    Parameters
    ----------
    run : Run
        A simulated run; its metadata holds ``speed_limit_clipped_steps`` (one count per
        motor), ``scenario``, ``duration_s`` and ``rates_hz["physics"]`` (Hz).

    Returns
    -------
    str or None
        ``note: ...`` with the limit (rad/s) and each side's or wheel's count of clipped
        steps out of the run's physics steps; None when no command was clipped.
    """
    counts = run.meta.get("speed_limit_clipped_steps") or []
    if not any(counts):
        return None
    vehicle = get_vehicle(run.vehicle)
    steps = physics_steps(run.meta["duration_s"], 1.0 / run.meta["rates_hz"]["physics"]) + 1
    sides = len(counts) == 2 and not vehicle.contact_geometry().steered
    names = ["left", "right"] if sides else [f"wheel {i + 1}" for i in range(len(counts))]
    per_motor = ", ".join(f"{name} {count}" for name, count in zip(names, counts))
    return (f"note: the {run.meta['scenario']} scenario asked for more than the wheel speed "
            f"limit ({vehicle.motor.max_wheel_speed_rad_s:.3g} rad/s): each "
            f"{'side' if sides else 'wheel'}'s command clipped to it on {per_motor} of "
            f"{steps} physics steps (the run does not follow the command there)")


def unconverged_steps_note(run: Run) -> str | None:
    """A note counting the physics steps whose implicit-Euler iterations did not converge.

    Each step's Newton iterations stop at :data:`terrain.sim.dynamics.IMPLICIT_MAX_ITERATIONS`;
    a step that has not reached the tolerance by then keeps its iterate of the smallest error
    (:func:`terrain.sim.dynamics.implicit_euler_step`).

    Parameters
    ----------
    run : Run
        A simulated run; its metadata holds ``implicit_unconverged_steps`` (a count).

    Returns
    -------
    str or None
        ``note: ...`` with the count; None when every step converged (or the metadata,
        written before 2026-11-30, has no count).
    """
    count = run.meta.get("implicit_unconverged_steps") or 0
    if not count:
        return None
    return (f"note: {count} physics step(s) of the implicit Euler integrator stopped at "
            f"{IMPLICIT_MAX_ITERATIONS} Newton iterations before reaching its tolerance "
            f"(each keeps its iterate of the smallest error)")


def unreached_terrains_note(run: Run, config: SimConfig) -> str | None:
    """A note naming the listed terrains a simulated run never reached, or None.

    The terrain changes every ``config.segment_length_m`` of travelled distance, so a short or
    slow run, or a spin in place, may end on the first terrains of the list.

    Parameters
    ----------
    run : Run
        The simulated run; its ``truth`` stream holds ``x``, ``y`` (m) and ``terrain`` per
        physics step.
    config : SimConfig
        Its configuration (``terrains``, ``segment_length_m``).

    Returns
    -------
    str or None
        ``note: ...`` with the terrains never reached, the distance the path covers and
        the terrains the run holds; None when every listed terrain is in the run.
    """
    truth = run.streams["truth"]
    reached = list(dict.fromkeys(truth["terrain"].astype(str)))
    unreached = [t for t in dict.fromkeys(config.terrains) if t not in reached]
    if not unreached:
        return None
    path_m = float(np.hypot(np.diff(truth["x"].to_numpy(float)),
                            np.diff(truth["y"].to_numpy(float))).sum())
    return (f"note: terrain(s) {', '.join(unreached)} never reached: the path covers "
            f"{path_m:.1f} m and the terrain changes every {config.segment_length_m:g} m "
            f"(--segment-m); the run holds {', '.join(reached)} only")
