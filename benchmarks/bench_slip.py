"""Benchmark: learned slip model inference cost per window, in-process (issue 10 target < 0.2 ms).

Fits :class:`terrain.slip.learned.SlipRegressor` (default settings, as ``terrain slip-fit``)
on the windows of a small cached simulated grid (:mod:`terrain.slip.dataset`), then times
``predict`` on the feature table:

* ``batch_ms_per_window``: one call on all windows, divided by their number (best of
  ``--repeats``); the cost per window when windows are scored together (a run, a stream
  buffer);
* ``single_ms_per_window``: one call per window (a single-row table), median over
  ``--singles`` calls; the latency of scoring one new window alone;
* ``features_ms_per_window``: feature extraction (:func:`features.slip_features.slip_features`,
  physics slip included) per window, for context.

OpenMP is limited to one thread for the whole benchmark (threadpoolctl): on the shared 2-core
machine the tree ensemble's OpenMP pool otherwise spins against other processes and a single
call can take hundreds of milliseconds. Logged to MLflow (experiment ``terrain-benchmark``).

Run: ``python benchmarks/bench_slip.py [--cache-dir out/slip_cache] [--no-mlflow]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from threadpoolctl import threadpool_limits

from features.slip_features import one_hot_probabilities, slip_features, slip_table, slip_windows
from terrain.slip.dataset import SlipDataSpec, simulated_runs
from terrain.slip.learned import SLIP_OUTPUTS, SlipRegressor
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.tracking import tracked_run
from terrain.vehicles import HUSKY


def main() -> None:
    """Fit, time, print, log."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache-dir", default="out/slip_cache")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--singles", type=int, default=200)
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    spec = SlipDataSpec(terrains=("ASPHALT", "SANDY_LOAM", "SNOW", "ICE", "GRASS"),
                        scenarios=("straight_accel", "orchard", "slope_turn", "random"),
                        seeds=(0, 1))
    runs = simulated_runs(spec, args.cache_dir)
    with threadpool_limits(1, "openmp"):
        X, Y, _ = slip_table(runs, HUSKY, TERRAIN_NAMES)
        model = SlipRegressor().fit(X, Y[list(SLIP_OUTPUTS)].to_numpy())
        n = len(X)
        batch = min(_timed(lambda: model.predict(X)) for _ in range(args.repeats)) / n
        rows = np.random.default_rng(0).integers(0, n, args.singles)
        single = float(np.median([_timed(lambda i=i: model.predict(X.iloc[[i]]))
                                  for i in rows]))
        ws = slip_windows(runs[:4])
        probs = one_hot_probabilities(["ASPHALT"] * len(ws), TERRAIN_NAMES)
        feat = min(_timed(lambda: slip_features(ws, HUSKY, probs)) for _ in range(3)) / len(ws)
    result = {"batch_ms_per_window": 1e3 * batch, "single_ms_per_window": 1e3 * single,
              "features_ms_per_window": 1e3 * feat, "n_windows": float(n),
              "n_features": float(X.shape[1])}
    for k, v in result.items():
        print(f"{k:>24s}: {v:.4f}")
    print(f"target < 0.2 ms per window: batch {'met' if batch * 1e3 < 0.2 else 'NOT met'}, "
          f"single call {'met' if single * 1e3 < 0.2 else 'NOT met'}")
    if not args.no_mlflow:
        with tracked_run("terrain-benchmark", "bench_slip", {"benchmark": "slip"}) as run:
            run.log_metrics(result)


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
