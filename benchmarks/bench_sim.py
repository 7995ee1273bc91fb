"""Benchmark: simulate 10 minutes of each vehicle with every sensor at its rate.

Each vehicle first simulates ``WARMUP_S`` seconds untimed (the process's one-off costs), then
the timed run. Prints seconds per simulated minute and the real-time factor, and logs them
to MLflow (experiment ``terrain-benchmark``). Run: ``python benchmarks/bench_sim.py [--minutes 10]
[--physics v1|v2] [--terrains ASPHALT,GRASS]`` (v2 on ``SANDY_LOAM,SNOW`` exercises the
lateral wheel-soil model).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

from terrain.sim import SimConfig, simulate
from terrain.sim.forces import DEFAULT_PHYSICS, PHYSICS_VERSIONS
from terrain.tracking import tracked_run

#: Simulated seconds of each vehicle's untimed warm-up run (the first simulation of a
#: process pays lazy imports and numba cache loads, 0.2-0.25 s on the 2-core machine).
WARMUP_S = 2.0


def main() -> int:
    """Run the benchmark; returns 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--physics", choices=list(PHYSICS_VERSIONS), default=DEFAULT_PHYSICS)
    parser.add_argument("--terrains", default="ASPHALT,GRASS",
                        help="comma-separated terrain sequence")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    duration = 60.0 * args.minutes
    metrics = {}
    for vehicle in ("husky", "agrimaro", "tracked"):
        cfg = SimConfig(vehicle=vehicle, terrains=tuple(args.terrains.split(",")),
                        scenario="random", duration_s=duration, seed=0, physics=args.physics)
        simulate(replace(cfg, duration_s=WARMUP_S))      # untimed: the process's one-off costs
        start = time.perf_counter()
        simulate(cfg)
        elapsed = time.perf_counter() - start
        metrics[f"{vehicle}_s_per_sim_min"] = elapsed / args.minutes
        metrics[f"{vehicle}_realtime_factor"] = duration / elapsed
        print(f"{vehicle:9s} {elapsed / args.minutes:6.3f} s per simulated minute, "
              f"{duration / elapsed:6.1f}x real time")
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
