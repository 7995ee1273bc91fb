"""Benchmark: simulate 10 minutes of each vehicle with every sensor at its rate.

Each vehicle first simulates ``WARMUP_S`` seconds untimed (the process's one-off costs), then
the timed run. Prints seconds per simulated minute (wall clock, and CPU time of this process,
``*_cpu_s_per_sim_min``) and the real-time factor. A fixed single-threaded NumPy workload
(``reference_ms``: :mod:`pipelines.reference_workload`, sorting 4096 floats, median of 200,
timed before and after the simulations and averaged) is the reference of the same run:
``{vehicle}_over_reference`` is the wall milliseconds per simulated minute over its
milliseconds, comparable between a loaded
and a quiet machine where the absolute figures are not. Logged to MLflow (experiment
``terrain-benchmark``). Run: ``python benchmarks/bench_sim.py [--minutes 10]
[--physics v1|v2] [--terrains ASPHALT,GRASS]`` (v2 on ``SANDY_LOAM,SNOW`` exercises the
lateral wheel-soil model). ``--terrains`` is read as ``terrain simulate --terrain`` reads
it; a list or a length the simulator refuses is a usage error before anything is timed.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

from pipelines.arguments import positive_number
from pipelines.reference_workload import sort_reference_ms as reference_ms
from terrain.errors import ConfigError
from terrain.sim import SimConfig, parse_terrain_list, simulate
from terrain.sim.forces import DEFAULT_PHYSICS, PHYSICS_VERSIONS
from terrain.tracking import require_store, tracked_run

#: Simulated seconds of each vehicle's untimed warm-up run (the first simulation of a
#: process pays lazy imports and numba cache loads, 0.2-0.25 s on the 2-core machine).
WARMUP_S = 2.0


def main() -> int:
    """Run the benchmark; returns 0."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=positive_number, default=10.0)
    parser.add_argument("--physics", choices=list(PHYSICS_VERSIONS), default=DEFAULT_PHYSICS)
    parser.add_argument("--terrains", default="ASPHALT,GRASS",
                        help="comma-separated terrain sequence")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    duration = 60.0 * args.minutes
    try:        # the simulator's checks (names, longest run, each vehicle's shortest) first
        configs = [SimConfig(vehicle=vehicle, terrains=parse_terrain_list(args.terrains),
                             scenario="random", duration_s=duration, seed=0,
                             physics=args.physics) for vehicle in ("husky", "agrimaro",
                                                                   "tracked")]
    except ConfigError as exc:
        parser.error(f"argument --minutes / --terrains: {args.minutes:g} min of "
                     f"{args.terrains!r}: {exc}")
    metrics = {}
    ref_before = reference_ms()
    for cfg in configs:
        vehicle = cfg.vehicle
        simulate(replace(cfg, duration_s=WARMUP_S))      # untimed: the process's one-off costs
        start, cpu_start = time.perf_counter(), time.process_time()
        simulate(cfg)
        elapsed = time.perf_counter() - start
        metrics[f"{vehicle}_cpu_s_per_sim_min"] = (time.process_time() - cpu_start) / args.minutes
        metrics[f"{vehicle}_s_per_sim_min"] = elapsed / args.minutes
        metrics[f"{vehicle}_realtime_factor"] = duration / elapsed
    metrics["reference_ms"] = 0.5 * (ref_before + reference_ms())
    for vehicle in ("husky", "agrimaro", "tracked"):
        per_min = metrics[f"{vehicle}_s_per_sim_min"]
        metrics[f"{vehicle}_over_reference"] = 1e3 * per_min / metrics["reference_ms"]
        print(f"{vehicle:9s} {per_min:6.3f} s per simulated minute "
              f"({metrics[f'{vehicle}_cpu_s_per_sim_min']:.3f} s CPU), "
              f"{metrics[f'{vehicle}_realtime_factor']:6.1f}x real time, "
              f"{metrics[f'{vehicle}_over_reference']:.0f} x the reference")
    print(f"reference (sort of 4096 floats) {metrics['reference_ms']:.4f} ms "
          f"(before {ref_before:.4f} ms)")
    if not args.no_mlflow:
        with tracked_run("terrain-benchmark", run_name="bench_sim",
                         params={"minutes": args.minutes, "physics_rate_hz": 100,
                                 "scenario": "random", "physics": args.physics,
                                 "warmup_s": WARMUP_S,
                                 "terrains": args.terrains}) as run:
            run.log_metrics(metrics)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
