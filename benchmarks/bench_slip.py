"""Benchmark: learned slip model inference cost per window, in-process (issue 10 target < 0.2 ms).

Fits :class:`terrain.slip.learned.SlipRegressor` (default settings, as ``terrain slip-fit``)
on the windows of a small cached simulated grid (:mod:`terrain.slip.dataset`), then times, in
the same process and run:

* ``batch_ms_per_window``: ``predict`` (compiled tree adaptor,
  :mod:`terrain.tree_predict`) on all windows in one call, divided by their number (best
  of ``--repeats``); the cost per window when windows are scored together (a run, a buffer);
* ``single_ms_per_window``: ``predict`` on one window (a 1-row array), median over
  ``--singles`` calls; the latency of scoring one new window alone;
* ``reference_batch_ms_per_window`` / ``reference_single_ms_per_window``: the same with
  scikit-learn's own ``predict`` (:meth:`SlipRegressor.predict_reference`), the reference
  measured under the same machine load (its single-window median over fewer calls, the
  first ``max(20, --singles // 10)`` of the same windows, at most ``--singles``: one call
  takes milliseconds); ``batch_over_reference`` /
  ``single_over_reference``: ours over it (comparable between a loaded and a quiet machine);
* ``features_ms_per_window``: feature table of a run (:func:`features.slip_features.slip_features`,
  physics slip included) per window; ``single_features_ms``: the NumPy single-window path
  (:func:`features.slip_features.window_feature_vector`) for one window;
  ``single_end_to_end_ms``: single-window features + ``predict``;
  ``single_std_ms_per_window``: the calibrated std (:meth:`SlipRegressor.predict_std`) of one
  window.

The outputs of the compiled and reference paths are checked to be identical before timing.

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

from features.slip_features import (one_hot_probabilities, slip_features, slip_table,
                                    slip_windows, window_feature_vector)
from pipelines.arguments import positive_integer
from terrain.slip.dataset import SlipDataSpec, simulated_runs
from terrain.slip.learned import SLIP_OUTPUTS, SlipRegressor
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.tracking import require_store, tracked_run
from terrain.vehicles import HUSKY


def main() -> None:
    """Fit, time, print, log."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--cache-dir", default="out/slip_cache")
    parser.add_argument("--repeats", type=positive_integer, default=5)
    parser.add_argument("--singles", type=positive_integer, default=200)
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    spec = SlipDataSpec(terrains=("ASPHALT", "SANDY_LOAM", "SNOW", "ICE", "GRASS"),
                        scenarios=("straight_accel", "orchard", "slope_turn", "random"),
                        seeds=(0, 1))
    runs = simulated_runs(spec, args.cache_dir)
    with threadpool_limits(1, "openmp"):
        X, Y, meta = slip_table(runs, HUSKY, TERRAIN_NAMES)
        model = SlipRegressor().fit(X, Y[list(SLIP_OUTPUTS)].to_numpy(),
                                    groups=meta["run_id"].to_numpy())
        n = len(X)
        Xa = X.to_numpy(float)
        if not np.array_equal(model.predict(Xa), model.predict_reference(Xa)):
            raise AssertionError("compiled and reference predictions differ")
        rows = np.random.default_rng(0).integers(0, n, args.singles)
        result = {}
        for name, fn in (("", model.predict), ("reference_", model.predict_reference)):
            batch = min(_timed(lambda: fn(Xa)) for _ in range(args.repeats)) / n
            k = args.singles if not name else max(20, args.singles // 10)
            single = float(np.median([_timed(lambda i=i: fn(Xa[i:i + 1])) for i in rows[:k]]))
            result[f"{name}batch_ms_per_window"] = 1e3 * batch
            result[f"{name}single_ms_per_window"] = 1e3 * single
        result["single_std_ms_per_window"] = 1e3 * float(np.median(
            [_timed(lambda i=i: model.predict_std(Xa[i:i + 1])) for i in rows]))
        ws = slip_windows(runs[:4])
        probs = one_hot_probabilities(["ASPHALT"] * len(ws), TERRAIN_NAMES)
        p1 = {t: float(t == "ASPHALT") for t in TERRAIN_NAMES}
        feat = min(_timed(lambda: slip_features(ws, HUSKY, probs)) for _ in range(3)) / len(ws)
        one = [_timed(lambda i=i: window_feature_vector(ws.X[i % len(ws)], ws.channels,
                                                        ws.rate_hz, HUSKY, p1))
               for i in range(args.singles)]
        e2e = [_timed(lambda i=i: model.predict(window_feature_vector(
            ws.X[i % len(ws)], ws.channels, ws.rate_hz, HUSKY, p1)[None]))
            for i in range(args.singles)]
    result.update({"features_ms_per_window": 1e3 * feat,
                   "single_features_ms": 1e3 * float(np.median(one)),
                   "single_end_to_end_ms": 1e3 * float(np.median(e2e)),
                   "n_windows": float(n), "n_features": float(X.shape[1])})
    result.update(reference_ratios(result))
    for k, v in result.items():
        print(f"{k:>32s}: {v:.4f}")
    print(f"target < 0.2 ms per window (model inference): batch "
          f"{'met' if result['batch_ms_per_window'] < 0.2 else 'NOT met'}, single call "
          f"{'met' if result['single_ms_per_window'] < 0.2 else 'NOT met'}")
    if not args.no_mlflow:
        with tracked_run("terrain-benchmark", "bench_slip", {"benchmark": "slip"}) as run:
            run.log_metrics(result)


def reference_ratios(result: dict[str, float]) -> dict[str, float]:
    """The compiled path's time per window over scikit-learn's, measured in the same run.

    Parameters
    ----------
    result : dict
        ``batch_ms_per_window``, ``single_ms_per_window`` and their ``reference_`` twins, ms.

    Returns
    -------
    dict
        ``batch_over_reference`` and ``single_over_reference`` (dimensionless; below 1: the
        compiled path is faster), comparable between a loaded and a quiet machine.
    """
    return {f"{mode}_over_reference": result[f"{mode}_ms_per_window"]
            / result[f"reference_{mode}_ms_per_window"] for mode in ("batch", "single")}


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
