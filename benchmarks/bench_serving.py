"""Benchmark: in-process decision latency and a 30-minute soak of the streaming service.

* Latency: a BorealTC run (IMU + wheels) is replayed sample by sample through
  :class:`terrain.serving.StreamService`; every ``push`` that completes exactly one
  decision is timed (alignment of the window, features, classifier, forward filter, slip
  target), after ``--warmup`` decisions. p50 / p99 / max are reported (target p99 < 1 ms).
  The model's own pipeline (features + classifier) is timed twice: inside each timed
  decision, where the service calls it (``pipeline_in_decision_*``; the rest of that
  decision is the service's own work, ``service_own_*``, the paired difference), and right
  after it on one batch window of the same run (``pipeline_*``, with
  ``service_overhead_*`` = decision - that call, the split reported before). The second
  call finds the model's arrays in the CPU caches the first one filled, so it is the
  faster of the two; the difference is what a decision pays for its model being cold.
* Soak: held-out-style runs are strung into one stream of >= ``--minutes`` minutes
  (:func:`terrain.serving.evaluation.concatenated_streams`, seeded) and replayed faster
  than real time; resident set size (RSS) is sampled every 1000 pushes; peak RSS and its
  growth after the first 2 minutes of stream are reported (target growth < 20 MB).

The model is trained here on BorealTC with the ``--kind`` recipe
(:data:`terrain.serving.recipes.RECIPES`; default the default all-signal recipe,
:data:`~terrain.serving.recipes.DEFAULT_RECIPES`), or read with ``--model DIR`` (then
its own channels choose the streams replayed,
:func:`~terrain.serving.evaluation.model_stream_names`, and ``--kind`` is not used). Results
print and are logged to MLflow (experiment ``terrain-benchmark``).

Every timed decision is followed by a fixed NumPy reference workload (a sort of 4096
floats, :mod:`pipelines.reference_workload`); the ratio of the decision's p50 / p99 to the
reference's is printed and logged, so runs on a shared, loaded machine can be compared.

Run: ``python benchmarks/bench_serving.py [--kind KIND] [--minutes 30] [--no-mlflow]``, KIND
one of ``all-dense`` (default), ``all``, ``all-ensemble``, ``all-ensemble-dense``,
``all-ensemble3``, ``wheels``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
from pathlib import Path

import numpy as np
import psutil

from features.windows import WindowConfig, make_windows
from pipelines.arguments import integer_in, non_negative_number
from pipelines.reference_workload import sort_reference_s
from terrain.errors import ConfigError
from terrain.io.shipped import load_dataset
from terrain.models.window_ekf import WindowEKFClassifier
from terrain.run import TIME
from terrain.serving import (CataloguePeakTargets, StreamConfig, StreamService,
                             interleave, load_stream_model)
from terrain.serving.evaluation import (concatenated_streams, model_stream_names,
                                        recipe_stream_names)
from terrain.serving.recipes import DEFAULT_RECIPES, RECIPES, fit_stream_model
from terrain.tracking import require_store, tracked_run


def _pushes(service, run):
    """(stream, t, values-dict) of a run in timestamp order, one sample each."""
    cols = {s: [c for c in run.streams[s].columns if c != TIME] for s in run.streams}
    for stream, t, v in interleave(run, service.needed_streams):
        yield stream, t, dict(zip(cols[stream], v.T))


class _TimedPipeline:
    """The model's pipeline as the service sees it (``classes_``, ``predict_proba``), timing
    each ``predict_proba`` call (``last_s``, s)."""

    def __init__(self, pipeline) -> None:
        self.pipeline, self.classes_, self.last_s = pipeline, pipeline.classes_, 0.0

    def predict_proba(self, X):
        start = time.perf_counter()
        out = self.pipeline.predict_proba(X)
        self.last_s = time.perf_counter() - start
        return out


def latency(model, run, warmup: int) -> dict[str, np.ndarray]:
    """Seconds, per push that completed exactly one decision after ``warmup``: the push
    (``decision``); the model's pipeline (features + classifier, ``predict_proba``) inside
    it (``in_decision``); the same pipeline on one batch window of the same run, right after
    the decision (``hot``); the reference workload (``reference``)."""
    timed = _TimedPipeline(model.pipeline)
    svc = StreamService(dataclasses.replace(model, pipeline=timed),
                        CataloguePeakTargets(model.classes), StreamConfig(hop_s=0.5))
    windows = make_windows([run], model.channels, WindowConfig(
        window_s=model.window.window_s, hop_s=0.5, rate_hz=model.window.rate_hz)).X
    out = {k: [] for k in ("decision", "in_decision", "hot", "reference")}
    n = 0
    for stream, t, v in _pushes(svc, run):
        timed.last_s = 0.0
        start = time.perf_counter()
        decided = svc.push(stream, t, v)
        elapsed = time.perf_counter() - start
        if len(decided) == 1:
            n += 1
            if n > warmup:
                out["decision"].append(elapsed)
                out["in_decision"].append(timed.last_s)
                x = windows[n % len(windows)][None]
                start = time.perf_counter()
                model.pipeline.predict_proba(x)
                out["hot"].append(time.perf_counter() - start)
                out["reference"].append(sort_reference_s())
    return {k: np.asarray(v) for k, v in out.items()}


def pipeline_parts(model, run, repeats: int = 7, number: int = 50) -> dict:
    """Best-of-``repeats`` ms of the model pipeline's parts on one window of ``run`` (load
    mostly drops out): features (``pipeline[:-1].transform``), classifier (the final step's
    ``predict_proba`` on those features, scikit-learn's path) and the whole pipeline's
    ``predict_proba`` (the path the service takes: compiled / NumPy where it applies); for a
    ``--window-ekf`` model the EKF channels (``augment``) and the whole ``predict_proba``.
    Empty for other models that are not a ``Pipeline`` (e.g. the ensemble)."""
    import timeit

    from sklearn.pipeline import Pipeline

    pipe = model.pipeline
    if not isinstance(pipe, (Pipeline, WindowEKFClassifier)):
        return {}
    x = make_windows([run], model.channels, WindowConfig(
        window_s=model.window.window_s, hop_s=0.5, rate_hz=model.window.rate_hz)).X[100][None]

    def best(f, n=number):
        return min(timeit.repeat(f, number=n, repeat=repeats)) / n * 1e3

    if isinstance(pipe, WindowEKFClassifier):
        # the EKF channels of the window, then the wrapped classifier
        return {"part_window_ekf_ms": best(lambda: pipe.augment(x)),
                "part_pipeline_ms": best(lambda: pipe.predict_proba(x))}
    features = pipe[:-1].transform(x)

    return {"part_features_ms": best(lambda: pipe[:-1].transform(x)),
            "part_classifier_sklearn_ms": best(lambda: pipe.steps[-1][1].predict_proba(
                features), max(1, number // 10)),
            "part_pipeline_ms": best(lambda: pipe.predict_proba(x))}


def soak(model, run, sample_every: int = 1000) -> dict:
    """Replay ``run`` once; RSS samples, decisions and wall time."""
    proc = psutil.Process()
    svc = StreamService(model, CataloguePeakTargets(model.classes), StreamConfig(hop_s=0.5))
    t_stream, rss, n_dec = [], [], 0
    start = time.perf_counter()
    for k, (stream, t, v) in enumerate(_pushes(svc, run)):
        n_dec += len(svc.push(stream, t, v))
        if k % sample_every == 0:
            t_stream.append(float(t[-1]))
            rss.append(proc.memory_info().rss / 2 ** 20)
    wall = time.perf_counter() - start
    t_stream, rss = np.asarray(t_stream), np.asarray(rss)
    after = rss[t_stream >= t_stream[0] + 120.0]
    return {"stream_s": float(t_stream[-1] - t_stream[0]), "wall_s": wall,
            "speedup_x": float((t_stream[-1] - t_stream[0]) / wall), "decisions": n_dec,
            "rss_peak_mb": float(rss.max()), "rss_after_2min_mb": float(after[0]),
            "rss_growth_mb": float(after.max() - after[0])}


def main() -> int:
    """Run the benchmark; returns 0."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--kind", choices=list(RECIPES), default=DEFAULT_RECIPES["all"])
    parser.add_argument("--model", type=Path, default=None, help="model directory to use")
    parser.add_argument("--minutes", type=non_negative_number, default=30.0,
                        help="soak stream length (0: no soak)")
    parser.add_argument("--warmup", type=integer_in(0, 100_000), default=20,
                        help="decisions not timed")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    runs = load_dataset("borealtc")
    if args.model:
        try:
            model = load_stream_model(args.model)
            need = model_stream_names(model)    # the model's streams, whatever --kind says
        except (ConfigError, OSError) as exc:
            parser.error(f"argument --model: {exc}")
    else:
        recipe = RECIPES[args.kind]
        need = recipe_stream_names(recipe)
        model = fit_stream_model(recipe, runs, seed=0)
    usable = [r for r in runs if all(s in r.streams for s in need)]
    longest = max(usable, key=lambda r: r.duration_s)
    timed = {k: v * 1e3 for k, v in latency(model, longest, args.warmup).items()}
    if not timed["decision"].size:      # every decision of the run was warm-up
        parser.error(f"argument --warmup: {args.warmup} warm-up decisions leave none of "
                     f"{longest.run_id}'s ({longest.duration_s:.0f} s) to time")
    lat, pipe, ref = timed["decision"], timed["hot"], timed["reference"]
    inside = timed["in_decision"]
    metrics = {"decision_p50_ms": float(np.percentile(lat, 50)),
               "decision_p99_ms": float(np.percentile(lat, 99)),
               "decision_max_ms": float(lat.max()), "decisions_timed": int(lat.size),
               "pipeline_p50_ms": float(np.percentile(pipe, 50)),
               "pipeline_p99_ms": float(np.percentile(pipe, 99)),
               "service_overhead_p50_ms": float(np.percentile(lat - pipe, 50)),
               "service_overhead_p99_ms": float(np.percentile(lat - pipe, 99)),
               "pipeline_in_decision_p50_ms": float(np.percentile(inside, 50)),
               "pipeline_in_decision_p99_ms": float(np.percentile(inside, 99)),
               "service_own_p50_ms": float(np.percentile(lat - inside, 50)),
               "service_own_p99_ms": float(np.percentile(lat - inside, 99)),
               "reference_p50_ms": float(np.percentile(ref, 50)),
               "reference_p99_ms": float(np.percentile(ref, 99))}
    metrics["decision_p50_over_reference"] = metrics["decision_p50_ms"] / metrics[
        "reference_p50_ms"]
    metrics["decision_p99_over_reference"] = metrics["decision_p99_ms"] / metrics[
        "reference_p99_ms"]
    # a model read with --model is not --kind's: name it by its folder
    source = {"model": str(args.model)} if args.model else {"kind": args.kind}
    print(f"model {next(iter(source.values()))} ({len(model.channels)} channels, "
          f"{model.window.window_s:g} s at {model.window.rate_hz:g} Hz); latency of one "
          f"decision on {longest.run_id}: "
          f"p50 {metrics['decision_p50_ms']:.3f} ms, p99 {metrics['decision_p99_ms']:.3f} ms, "
          f"max {metrics['decision_max_ms']:.3f} ms ({lat.size} decisions after "
          f"{args.warmup} warm-up); of which the model's pipeline (features + classifier "
          f"predict_proba, one window) inside the decision p50 "
          f"{metrics['pipeline_in_decision_p50_ms']:.3f} ms, p99 "
          f"{metrics['pipeline_in_decision_p99_ms']:.3f} ms, and the service's own work "
          f"(decision - that call) p50 {metrics['service_own_p50_ms']:.3f} ms, p99 "
          f"{metrics['service_own_p99_ms']:.3f} ms; the same pipeline timed again right "
          f"after the decision (caches warm) p50 {metrics['pipeline_p50_ms']:.3f} ms, p99 "
          f"{metrics['pipeline_p99_ms']:.3f} ms (decision - it: p50 "
          f"{metrics['service_overhead_p50_ms']:.3f} ms, p99 "
          f"{metrics['service_overhead_p99_ms']:.3f} ms); reference (sort of 4096 floats) p50 "
          f"{metrics['reference_p50_ms']:.4f} ms, p99 {metrics['reference_p99_ms']:.4f} ms; "
          f"ratio p50 {metrics['decision_p50_over_reference']:.1f}, p99 "
          f"{metrics['decision_p99_over_reference']:.1f}; load average "
          f"{os.getloadavg()[0]:.1f}")
    parts = pipeline_parts(model, longest)
    metrics.update(parts)
    if parts:
        print("model pipeline parts on one window (best of 7): "
              + ", ".join(f"{k[5:]} {v:.4f}" for k, v in parts.items()))
    if args.minutes > 0:
        metrics.update({f"soak_{k}": v for k, v in _soak(model, usable, need,
                                                         args.minutes).items()})
    if not args.no_mlflow:
        name = f"serving-{'model' if args.model else args.kind}"
        with tracked_run("terrain-benchmark", run_name=name,
                         params={**source, "minutes": args.minutes},
                         announce=False) as run:
            run.log_metrics(metrics)
        print(run.describe())
    return 0


def _soak(model, usable, need, minutes: float) -> dict:
    """Soak of a concatenated stream of at least ``minutes``; prints and returns the result."""
    stream, segments, seed = None, [], 0
    while stream is None or sum(s.duration_s for s in segments) < 60 * minutes:
        piece, segs = concatenated_streams(usable, need, seed)
        stream = piece if stream is None else _append(stream, piece)
        segments += segs
        seed += 1
    result = soak(model, stream)
    print(f"soak: {result['stream_s'] / 60:.1f} min stream in {result['wall_s']:.0f} s "
          f"({result['speedup_x']:.1f}x real time), {result['decisions']} decisions; RSS "
          f"peak {result['rss_peak_mb']:.1f} MB, growth after 2 min "
          f"{result['rss_growth_mb']:.2f} MB")
    return result


def _append(a, b):
    """Run ``b`` appended after run ``a`` on one clock."""
    import pandas as pd
    from dataclasses import replace

    end = max(f[TIME].iloc[-1] for f in a.streams.values()) + 0.1
    frames = {s: pd.concat([a.streams[s], b.streams[s].assign(**{TIME: b.streams[s][TIME]
                                                                 + end})], ignore_index=True)
              for s in a.streams}
    return replace(a, streams=frames)


if __name__ == "__main__":
    raise SystemExit(main())
