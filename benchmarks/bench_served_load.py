"""Benchmark: bounded load test of the served streaming model on 127.0.0.1.

A streaming model is fitted on BorealTC (the ``--kind`` recipe of
:mod:`terrain.serving.evaluation`, or read with ``--model DIR``, whose own channels then
choose the streams sent), saved as ``terrain train
--model-out`` would, and served by ``terrain serve`` (MLflow's scoring server app) on a free
loopback port. ``--requests`` requests (default 2,000), ``--concurrency`` at a time (default
4), each carrying ``--request-s`` seconds of raw logged streams of one run (long format,
streams interleaved as logged, a different slice each time), are sent; any answer other than
HTTP 200 with at least one decision row counts as an error (the number of rows is not
checked against the windows due in the slice). Throughput, error count and
request latency p50/p99 print and are logged to MLflow (experiment ``terrain-benchmark``).
The reference, in the same run: the first ``--reference`` bodies (default 500) decided
in-process, one at a time, by the model the server runs (the trained model as ``terrain
serve`` wraps it, ``mlflow.pyfunc.load_model(...).predict`` on the parsed frame); the served
throughput and p50 latency are also given as ratios to it (the cost of HTTP, JSON and the
server, and the gain or cost of the concurrency).

``--behind-long K`` measures instead what a robot's short request waits behind bulk logs: K
long requests (the longest runs with both streams, each repeated on a shifted clock until the
JSON body is as long as ``--long-bytes`` allows, e.g. 60,000-70,000 rows) are sent at once,
then, from 1 s later, ``--requests`` short ones (capped at 12), one a second, one at a time;
each short request's latency prints and the first one's and the largest of the others are
logged.

Run: ``python benchmarks/bench_served_load.py [--kind wheels|all] [--model DIR]
[--requests 2000] [--concurrency 4] [--reference 500] [--behind-long K] [--no-mlflow]``.
"""

from __future__ import annotations

import argparse
import json
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from pipelines.arguments import integer_in, positive_integer, positive_number
from pipelines.serve import is_served_model
from terrain.errors import ConfigError
from terrain.io.shipped import load_dataset
from terrain.run import TIME
from terrain.serving.evaluation import model_stream_names
from terrain.serving.pyfunc import save_model
from terrain.serving import load_stream_model
from terrain.serving.recipes import RECIPES, fit_stream_model
from terrain.tracking import require_store, tracked_run


def request_bodies(runs, streams, request_s: float, count: int, seed: int = 0) -> list[bytes]:
    """``count`` JSON bodies of ``request_s`` s slices of random runs (long format)."""
    rng = np.random.default_rng(seed)
    usable = [r for r in runs if all(s in r.streams for s in streams)
              and r.duration_s > request_s + 1]
    bodies = []
    for _ in range(count):
        run = usable[rng.integers(len(usable))]
        t0 = rng.uniform(0, run.duration_s - request_s) + run.streams[streams[0]][TIME].iloc[0]
        parts = [run.streams[s][(run.streams[s][TIME] >= t0)
                                & (run.streams[s][TIME] < t0 + request_s)].assign(stream=s)
                 for s in streams]
        frame = pd.concat(parts, ignore_index=True).sort_values(TIME, kind="stable")
        cols = ["stream", TIME] + [c for c in frame.columns if c not in ("stream", TIME)]
        split = json.loads(frame[cols].to_json(orient="split", index=False))
        bodies.append(json.dumps({"dataframe_split": split}).encode())
    return bodies


def long_bodies(runs, streams, count: int, max_bytes: int,
                max_span_s: float = 990.0) -> list[bytes]:
    """JSON bodies of the ``count`` longest runs holding ``streams`` and spanning at most
    ``max_span_s`` seconds, each run repeated on a clock shifted by its streams' span plus
    1 s as often as fits in ``max_bytes`` and ``max_span_s`` (the served model's 2,000
    decisions at a 0.5 s hop are 1,000 s; once at least)."""
    def span_s(run) -> float:
        return (max(run.streams[s][TIME].max() for s in streams)
                - min(run.streams[s][TIME].min() for s in streams) + 1.0)

    def body(run, repeats: int) -> bytes:
        span = span_s(run)
        parts = [run.streams[s].assign(**{TIME: run.streams[s][TIME] + k * span}, stream=s)
                 for k in range(repeats) for s in streams]
        frame = pd.concat(parts, ignore_index=True).sort_values(TIME, kind="stable")
        cols = ["stream", TIME] + [c for c in frame.columns if c not in ("stream", TIME)]
        split = json.loads(frame[cols].to_json(orient="split", index=False))
        return json.dumps({"dataframe_split": split}).encode()

    usable = sorted((r for r in runs if all(s in r.streams for s in streams)
                     and span_s(r) <= max_span_s), key=lambda r: -r.duration_s)[:count]
    return [body(r, max(1, min(int(max_bytes // len(body(r, 1))),
                               int(max_span_s // span_s(r))))) for r in usable]


def behind_long(base: str, longs: list[bytes], shorts: list[bytes]) -> dict:
    """Send ``longs`` at once, then ``shorts`` one a second from 1 s later, one at a time;
    returns the short requests' latencies (s) and whether every request was answered 200."""
    with ThreadPoolExecutor(len(longs)) as pool:
        pending = [pool.submit(_post, base + "/invocations", b) for b in longs]
        time.sleep(1.0)
        short = []
        for body in shorts:
            ok, latency = _post(base + "/invocations", body)
            short.append((ok, latency))
            print(f"short request {len(short)}: {latency:.2f} s", flush=True)
            time.sleep(max(0.0, 1.0 - latency))
        long = [f.result() for f in pending]
    return {"short_s": [r[1] for r in short], "long_s": [r[1] for r in long],
            "errors": sum(not r[0] for r in short + long)}


def in_process_latencies(model_dir: Path, bodies: list[bytes]) -> np.ndarray:
    """Seconds each body takes to decide in-process, one at a time, after one warm-up.

    Parameters
    ----------
    model_dir : Path
        The served streaming model (``terrain serve --served-out``: the trained model
        wrapped with the service's settings), whose ``predict`` the server calls.
    bodies : list of bytes
        JSON request bodies (``dataframe_split``), parsed before the clock starts.

    Returns
    -------
    ndarray, shape (len(bodies),)
        Wall-clock seconds of ``predict`` per body.
    """
    import mlflow.pyfunc

    model = mlflow.pyfunc.load_model(str(model_dir))
    frames = []
    for body in bodies:
        split = json.loads(body)["dataframe_split"]
        frames.append(pd.DataFrame(split["data"], columns=split["columns"]))
    if frames:
        model.predict(frames[0])  # warm-up, as for the server
    out = np.empty(len(frames))
    for i, frame in enumerate(frames):
        start = time.perf_counter()
        model.predict(frame)
        out[i] = time.perf_counter() - start
    return out


def _post(url: str, body: bytes) -> tuple[bool, float]:
    start = time.perf_counter()
    req = urllib.request.Request(url, body, {"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=300) as res:
            ok = res.status == 200 and len(json.loads(res.read())["predictions"]) > 0
    except (urllib.error.URLError, OSError, ValueError, KeyError):
        ok = False
    return ok, time.perf_counter() - start


def _serve(model_dir: Path, served_out: Path | None = None) -> tuple[subprocess.Popen, str]:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    keep = [] if served_out is None else ["--served-out", str(served_out)]
    proc = subprocess.Popen([sys.executable, "-m", "terrain.cli", "serve", "--model",
                             str(model_dir), "--host", "127.0.0.1", "--port", str(port)] + keep,
                            stdout=subprocess.DEVNULL)
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 120
    while True:
        if proc.poll() is not None:
            raise RuntimeError("terrain serve exited before answering /ping")
        try:
            urllib.request.urlopen(base + "/ping", timeout=2).close()
            return proc, base
        except OSError:
            if time.monotonic() > deadline:
                proc.terminate()
                raise RuntimeError("terrain serve did not start within 120 s")
            time.sleep(0.3)


def main() -> int:
    """Run the benchmark; returns 0."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--kind", choices=list(RECIPES), default="wheels")
    parser.add_argument("--model", type=Path, default=None,
                        help="model directory of terrain train --model-out")
    parser.add_argument("--requests", type=positive_integer, default=2000)
    parser.add_argument("--concurrency", type=positive_integer, default=4)
    parser.add_argument("--request-s", type=positive_number, default=4.0,
                        help="seconds of stream per request")
    parser.add_argument("--reference", type=integer_in(0, 100_000), default=500, metavar="N",
                        help="bodies decided in-process as the same-run reference (0: none)")
    parser.add_argument("--behind-long", type=integer_in(0, 100), default=0, metavar="K",
                        help="send K long requests at once, then short ones behind them")
    parser.add_argument("--long-bytes", type=positive_integer, default=7_500_000,
                        help="largest long request body, bytes (the server's limit: 8 MB)")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    runs = load_dataset("borealtc")
    # a model read with --model is not --kind's: its own channels choose the streams sent,
    # and its folder names it in the output and the MLflow run
    args.label = str(args.model) if args.model else args.kind
    args.source = {"model": str(args.model)} if args.model else {"kind": args.kind}
    with tempfile.TemporaryDirectory() as tmp:
        model_dir = args.model
        if model_dir is None:
            m = fit_stream_model(RECIPES[args.kind], runs, seed=0)
            model_dir = save_model(Path(tmp) / "model", m.pipeline, m.channels, m.window,
                                   m.classes, {"dataset": "borealtc", "kind": args.kind})
        try:
            model = load_stream_model(model_dir)
            streams = model_stream_names(model)
        except (ConfigError, OSError) as exc:     # --model DIR that holds no model
            parser.error(f"argument --model: {exc}")
        window = model.window
        request_s = max(args.request_s, window.window_s + 1.0)
        longest = max((r.duration_s for r in runs if all(s in r.streams for s in streams)),
                      default=0.0)
        if request_s + 1.0 >= longest:  # no run to slice a request from
            parser.error(f"argument --request-s: {request_s:g} s per request, but the longest "
                         f"BorealTC run with {' and '.join(streams)} lasts {longest:.0f} s")
        if args.behind_long:
            return _behind_long(args, runs, streams, model_dir, request_s)
        bodies = request_bodies(runs, streams, request_s, args.requests)
        # the reference decides with the streaming model the server runs (terrain serve
        # wraps a trained model into it; --served-out keeps that copy)
        served = model_dir if is_served_model(model_dir) else Path(tmp) / "served"
        proc, base = _serve(model_dir, None if served == model_dir else served)
        try:
            _post(base + "/invocations", bodies[0])  # warm-up
            start = time.perf_counter()
            with ThreadPoolExecutor(args.concurrency) as pool:
                results = list(pool.map(lambda b: _post(base + "/invocations", b), bodies))
            wall = time.perf_counter() - start
        finally:
            proc.terminate()
            proc.wait(timeout=20)
        reference = in_process_latencies(served, bodies[:args.reference]) * 1e3
    lat = np.array([r[1] for r in results]) * 1e3
    errors = int(sum(not r[0] for r in results))
    metrics = {"served_requests": len(results), "served_errors": errors,
               "served_throughput_rps": len(results) / wall, "served_wall_s": wall,
               "served_p50_ms": float(np.percentile(lat, 50)),
               "served_p99_ms": float(np.percentile(lat, 99))}
    print(f"served model {args.label} ({window.window_s:g} s windows): {len(results)} requests "
          f"of {request_s:g} s of stream, {args.concurrency} concurrent, in {wall:.1f} s: "
          f"{metrics['served_throughput_rps']:.1f} req/s, {errors} errors; latency p50 "
          f"{metrics['served_p50_ms']:.1f} ms, p99 {metrics['served_p99_ms']:.1f} ms")
    if len(reference):
        metrics.update({"inprocess_p50_ms": float(np.percentile(reference, 50)),
                        "inprocess_p99_ms": float(np.percentile(reference, 99)),
                        "inprocess_throughput_rps": len(reference) / (reference.sum() / 1e3)})
        metrics["served_over_inprocess_throughput"] = (metrics["served_throughput_rps"]
                                                       / metrics["inprocess_throughput_rps"])
        metrics["served_over_inprocess_p50"] = (metrics["served_p50_ms"]
                                                / metrics["inprocess_p50_ms"])
        print(f"in-process reference ({len(reference)} of the same bodies, one at a time): "
              f"{metrics['inprocess_throughput_rps']:.1f} req/s, latency p50 "
              f"{metrics['inprocess_p50_ms']:.1f} ms, p99 {metrics['inprocess_p99_ms']:.1f} "
              f"ms; served / in-process: throughput "
              f"{metrics['served_over_inprocess_throughput']:.2f}x, p50 "
              f"{metrics['served_over_inprocess_p50']:.2f}x")
    if not args.no_mlflow:
        _log(f"served-load-{'model' if args.model else args.kind}", metrics,
             {**args.source, "requests": args.requests, "concurrency": args.concurrency,
              "request_s": request_s, "reference": len(reference)})
    return 0


def _behind_long(args, runs, streams, model_dir: Path, request_s: float) -> int:
    """The ``--behind-long`` measurement; returns 0."""
    longs = long_bodies(runs, streams, args.behind_long, args.long_bytes)
    shorts = request_bodies(runs, streams, request_s, min(args.requests, 12) + 1)
    proc, base = _serve(model_dir)
    try:
        _post(base + "/invocations", shorts[0])  # warm-up
        result = behind_long(base, longs, shorts[1:])
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    short = result["short_s"]
    metrics = {"behind_long_first_short_s": short[0],
               "behind_long_later_short_max_s": max(short[1:], default=float("nan")),
               "behind_long_long_max_s": max(result["long_s"]),
               "behind_long_errors": result["errors"]}
    print(f"served model {args.label}: {len(longs)} long requests of "
          f"{min(map(len, longs)) / 1e6:.1f}-{max(map(len, longs)) / 1e6:.1f} MB at once, "
          f"then {len(short)} of {request_s:g} s: first short {short[0]:.2f} s, later ones "
          f"at most {metrics['behind_long_later_short_max_s']:.2f} s; longest long request "
          f"{metrics['behind_long_long_max_s']:.1f} s; {result['errors']} errors")
    if not args.no_mlflow:
        _log(f"served-behind-long-{'model' if args.model else args.kind}", metrics,
             {**args.source, "behind_long": args.behind_long,
              "long_bytes": args.long_bytes, "request_s": request_s})
    return 0


def _log(run_name: str, metrics: dict, params: dict) -> None:
    """Log one benchmark run to MLflow (experiment ``terrain-benchmark``) and name it."""
    with tracked_run("terrain-benchmark", run_name=run_name, params=params,
                     announce=False) as run:
        run.log_metrics(metrics)
    print(run.describe())


if __name__ == "__main__":
    sys.exit(main())
