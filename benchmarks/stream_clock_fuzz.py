"""Random clock faults through the streaming service, compared with the clean replay.

Each seed draws a shipped BorealTC run with IMU (one not used to fit the models), a model
(all signals on 50 Hz, or wheels only on 20 Hz: small SVMs fitted here on two runs per
terrain, as in ``tests/serving/conftest.py``), a service configuration (buffer, backlog,
smoothing) and up to three faults per stream among: a forward or backward step of its
clock, a switch to ms or us, a pause (nothing sent), a lag (a stretch delivered late at
once), a re-send of its last samples, NaN values, a duplicated sample, a stray stamp, and a
constant offset (a stream on another clock from its first sample). Samples are delivered
in arrival order (the unperturbed time; chunks of 1-40 IMU and 1-3 wheel samples, sometimes
in a reused array; one seed in ten reorders chunks within 50 ms).

For every seed the same run is also replayed clean (offsets only); a scenario whose
decisions that are neither ``stale`` nor ``short`` are fewer than 60 % of those of the
clean replay, or of its own decisions (a pause makes fewer), without a ms/us clock (whose
samples are refused by design), is listed, and so are any exception and any sample still
held at the end. ``--out`` saves every decision and counter,
``--compare`` lists the seeds whose outcome differs from a saved file (a differential check
of a change to :mod:`terrain.serving.clocks`, :mod:`terrain.serving.intake` or
:mod:`terrain.serving.service`: run it before and after on the same seeds).

Run: ``python benchmarks/stream_clock_fuzz.py [--seeds 0 300] [--out F.pkl]
[--compare OLD.pkl]`` (about 2.5 min per 300 seeds on a 2-core machine; nothing is logged
to MLflow: it finds cases, it measures no target).
"""

from __future__ import annotations

import argparse
import pickle
import traceback

import numpy as np

from features.windows import WindowConfig, make_windows
from pipelines.arguments import output_file, seed_value
from terrain.io.shipped import read_shipped
from terrain.models.experiment import inference_pipeline
from terrain.models.svm import SVMConfig
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS
from terrain.serving import (CataloguePeakTargets, SmoothingConfig, StreamConfig,
                             StreamModel, StreamService)

CHANNELS = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
FAULTS = ("step_fwd", "step_back", "ms", "us", "pause", "lag", "resend", "nan", "dup",
          "stray")
CHUNKS = {"imu": (1, 1, 1, 3, 10, 40), "wheels": (1, 1, 1, 2, 3)}


def fit_models(runs):
    """The two small test models and the runs they never saw."""
    train = []
    for terrain in sorted({r.terrain for r in runs}):
        train += [r for r in runs if r.terrain == terrain and r.has_imu][:2]

    def fit(signals, rate_hz):
        config = WindowConfig(window_s=2.0, rate_hz=rate_hz)
        ws = make_windows(train, signals, config)
        labels = ws.labels.astype(str)
        pipe = inference_pipeline(ws, SVMConfig(probability=True)).fit(ws.X, labels)
        return StreamModel(pipe, ws.channels, config, tuple(np.unique(labels)))

    seen = {r.run_id for r in train}
    unseen = [r for r in runs if r.has_imu and r.run_id not in seen and r.duration_s > 40]
    return {"all": fit("all", 50.0), "wheel": fit("wheels", 20.0)}, unseen[:6]


def perturb(rng, t, v, arrival, stream, log, n_max):
    """Apply up to ``n_max`` random faults to one stream; stamps, values, arrival times."""
    t, v, arrival = t.copy(), v.copy(), arrival.copy()
    for _ in range(int(rng.integers(0, n_max + 1))):
        k, fault = int(rng.integers(1, len(t) - 1)), str(rng.choice(FAULTS))
        log.append((stream, fault, k))
        if fault == "step_fwd":
            t[k:] += float(rng.choice([2.0, 6.0, 30.0, 847.5, 3600.0]))
        elif fault == "step_back":
            t[k:] -= float(rng.choice([3.0, 10.0, 100.0, t[k] - t[0] + 1.0]))
        elif fault in ("ms", "us"):
            t[k:] *= 1000.0 if fault == "ms" else 1e6
        elif fault == "pause":
            cut = slice(k, k + int(rng.integers(5, 400)))
            t, v, arrival = np.delete(t, cut), np.delete(v, cut, axis=0), np.delete(arrival, cut)
        elif fault == "lag":
            m = int(rng.integers(5, 400))
            arrival[k:k + m] = arrival[min(k + m, len(arrival) - 1)]
        elif fault == "resend":
            m = int(rng.integers(1, min(k, 200) + 1))
            t = np.concatenate([t[:k], t[k - m:k], t[k:]])
            v = np.concatenate([v[:k], v[k - m:k], v[k:]])
            arrival = np.concatenate([arrival[:k], np.full(m, arrival[k - 1]), arrival[k:]])
        elif fault == "nan":
            v[k:k + int(rng.integers(1, 50))] = np.nan
        elif fault == "dup":
            t, v = np.insert(t, k, t[k]), np.insert(v, k, v[k], axis=0)
            arrival = np.insert(arrival, k, arrival[k])
        else:   # a stray stamp
            t[k] += float(rng.choice([50.0, 1e4]))
    return t, v, arrival


def scenario(seed, models, runs, clean=False):
    """Replay one seed's scenario (``clean``: its offsets only); its log, decisions and
    final counters."""
    rng = np.random.default_rng(seed)
    key = "all" if rng.random() < 0.6 else "wheel"
    model, run = models[key], runs[int(rng.integers(len(runs)))]
    kw = {"smoothing": SmoothingConfig(dwell_s=None) if rng.random() < 0.5
          else SmoothingConfig()}
    if rng.random() < 0.3:
        kw["buffer_samples"] = int(rng.choice([256, 1024]))
    if rng.random() < 0.3:
        kw["max_backlog_s"] = float(rng.choice([5.0, 20.0]))
    svc = StreamService(model, CataloguePeakTargets(model.classes), StreamConfig(**kw))
    streams = ["wheels"] + (["imu"] if key == "all" or rng.random() < 0.3 else [])
    log = [key, run.run_id, kw.get("buffer_samples"), kw.get("max_backlog_s")]
    reorder, n_max = rng.random() < 0.1, int(rng.choice([1, 1, 2, 3]))
    data = {}
    for s in streams:
        frame = run.streams[s]
        t, v = frame[TIME].to_numpy(float), frame[list(CHANNELS[s])].to_numpy(float)
        offset = float(rng.choice([0.0, 0.0, 0.0, 0.05, -0.3, 1e5]))
        faulty = perturb(np.random.default_rng(rng.integers(1 << 30)), t + offset, v, t,
                         s, log, n_max)
        data[s] = (t + offset, v, t) if clean else faulty
        if offset:
            log.append((s, "offset", offset))
    if reorder:
        log.append(("chunks", "reordered", 0))
    chunking = np.random.default_rng(seed + 10**6)
    jitter = np.random.default_rng(seed + 2 * 10**6)
    events = []
    for s, (t, _, arrival) in data.items():
        i, reuse = 0, chunking.random() < 0.2
        while i < len(t):
            j = min(i + int(chunking.choice(CHUNKS[s])), len(t))
            delay = jitter.random() * 0.05 if reorder else 0.0
            events.append((float(arrival[j - 1]) + delay, s, i, j, reuse))
            i = j
    events.sort(key=lambda e: (e[0], e[1]))
    spare = {s: np.empty((40, len(CHANNELS[s]))) for s in data}
    out = []
    for _, s, i, j, reuse in events:
        t, v, _ = data[s]
        values = v[i:j]
        if reuse:   # a robot filling one preallocated array
            values = spare[s][:j - i]
            values[:] = v[i:j]
        try:
            out.append([(d.t_s, d.terrain, d.flags, round(d.confidence, 12))
                        for d in svc.push(s, t[i:j].copy(), values)])
        except Exception as exc:   # noqa: BLE001 - a fuzzer records every failure
            out.append(("EXC", type(exc).__name__, str(exc)[:200]))
    return log, out, (svc.refused_samples, svc.held_samples, svc.clock_restarts,
                      svc.clock_offsets_s, svc.skipped_decisions)


def good_decisions(result) -> tuple[int, int]:
    """Decisions, and those neither ``stale`` nor ``short``."""
    decisions = [d for chunk in result[1] if isinstance(chunk, list) for d in chunk]
    return len(decisions), sum("stale" not in d[2] and "short" not in d[2]
                               for d in decisions)


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=seed_value, nargs=2, default=[0, 300],
                        metavar=("FIRST", "END"))
    parser.add_argument("--out", type=output_file, help="save every outcome (pickle)")
    parser.add_argument("--compare", help="a saved --out of another version")
    args = parser.parse_args()
    if args.seeds[1] <= args.seeds[0]:      # range(FIRST, END) would be empty
        parser.error(f"argument --seeds: END {args.seeds[1]} must be above FIRST "
                     f"{args.seeds[0]} (seeds FIRST to END - 1)")
    old = None
    if args.compare:        # read before the fuzz, not after it
        try:
            with open(args.compare, "rb") as f:
                old = pickle.load(f)
        except (OSError, EOFError, pickle.UnpicklingError) as exc:
            parser.error(f"argument --compare: cannot read {args.compare!r}: {exc}")
    models, runs = fit_models(read_shipped("borealtc"))
    results = {}
    for seed in range(*args.seeds):
        try:
            results[seed] = (scenario(seed, models, runs),
                             scenario(seed, models, runs, clean=True))
        except Exception:   # noqa: BLE001
            results[seed] = ("CRASH", traceback.format_exc())
    crashed = [k for k, r in results.items() if r[0] == "CRASH"]
    exceptions = [k for k, r in results.items() if k not in crashed
                  and any(isinstance(c, tuple) for c in r[0][1])]
    held = {k: r[0][2][1] for k, r in results.items() if k not in crashed and r[0][2][1]}
    print(f"{len(results)} scenarios; crashed {crashed}; raised {exceptions}; "
          f"held at the end {held}")
    for k, (faulty, clean) in ((k, r) for k, r in results.items() if k not in crashed):
        (n, good), (_, good_clean) = good_decisions(faulty), good_decisions(clean)
        units = any(len(x) > 1 and x[1] in ("ms", "us") for x in faulty[0][4:])
        if good_clean > 20 and good < 0.6 * min(n, good_clean) and not units:
            print(f"seed {k}: {good} of {n} decisions clean (clean replay {good_clean}); "
                  f"refused {faulty[2][0]}; offsets {faulty[2][3]}; {faulty[0]}")
    if args.out:
        with open(args.out, "wb") as f:
            pickle.dump(results, f)
    if old is not None:
        changed = [k for k in results if k in old and old[k][0] != results[k][0]]
        better = sum(good_decisions(results[k][0])[1] > good_decisions(old[k][0])[1]
                     for k in changed)
        worse = sum(good_decisions(results[k][0])[1] < good_decisions(old[k][0])[1]
                    for k in changed)
        print(f"against {args.compare}: {len(changed)} of {len(results)} change "
              f"({better} with more clean decisions, {worse} with fewer): {changed}")


if __name__ == "__main__":
    main()
