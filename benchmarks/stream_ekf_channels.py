"""Would EKF channels lift the held-out stream accuracy? An offline A/B on the stream protocol.

The model comparison (docs/model_comparison_grid.md) found that the skid-steer EKF's channels
(``all+ekf``) lift the SVM + spectrogram-CNN vote on BorealTC from 0.883 to 0.920 per 2 s
window. Part of that may be history: the filter runs over the whole run, and its slow states
(ICR expansion chi, gyro bias) carry the run's past. On a stream that switches terrain that
memory could cost switching delay. The streaming service does not run the EKF, so this
benchmark measures the effect *offline* on the same held-out streams as
``terrain stream-eval`` (:func:`terrain.serving.evaluation.held_out_streams`: the same folds
over runs, the same seeded concatenated streams on a continuous clock):

* per fold, the equal-weight ``ensemble`` (SVM + spectrogram CNN, ``terrain train --model
  ensemble``) is fitted on the training runs' non-overlapping 2 s windows, once on ``all``
  and once on ``all+ekf``;
* the held-out stream is aligned once and the EKF run causally over the *whole stream*
  (:func:`features.windows.make_windows` on the concatenated run), as an EKF inside the
  service would run across the switches; windows of 2 s end every 0.5 s (the service's
  hop), each classified; a missing window is a prediction-only step;
* both arms go through the same forward filter (the service's default, dwell 10 s, power
  0.5) and are scored by :func:`terrain.serving.evaluation.score_stream` (per-decision
  accuracy, settled accuracy, median switching delay).

Both arms share this offline path, so their difference is the EKF channels'. The figures
are not those of ``terrain stream-eval`` (which replays sample by sample through the
service, with dense training windows).

Run: ``python benchmarks/stream_ekf_channels.py [--seeds 0 1 2] [--no-mlflow]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

from features.windows import WindowConfig, make_windows
from terrain.io.shipped import load_dataset
from terrain.models.cv import iter_splits
from terrain.models.registry import ModelConfig, make_model
from terrain.serving.evaluation import (concatenated_streams, filter_sequence, pool_scores,
                                        score_stream)
from terrain.serving.smoothing import SmoothingConfig
from terrain.tracking import tracked_run

WINDOW_S, HOP_S, RATE_HZ = 2.0, 0.5, 100.0
ARMS = ("all", "all+ekf")


def stream_proba(model, stream, signals: str, n_classes: int) -> tuple[np.ndarray, np.ndarray]:
    """Class probabilities of windows ending every ``HOP_S`` on a concatenated stream.

    Parameters
    ----------
    model : classifier
        Fitted on raw windows of ``signals``.
    stream : Run
        Concatenated run.
    signals : str
        Signal set (EKF channels are computed causally over the whole stream).
    n_classes : int
        Columns of the result.

    Returns
    -------
    t_s : numpy.ndarray
        ``(n,)`` decision times on a regular ``HOP_S`` grid, s.
    proba : numpy.ndarray
        ``(n, n_classes)``; NaN rows where no valid window ends (gaps).
    """
    ws = make_windows([stream], signals, WindowConfig(window_s=WINDOW_S, hop_s=HOP_S,
                                                      rate_hz=RATE_HZ))
    t_end = ws.t_end_s
    grid = np.arange(t_end.min(), t_end.max() + HOP_S / 2, HOP_S)
    proba = np.full((len(grid), n_classes), np.nan)
    idx = np.rint((t_end - grid[0]) / HOP_S).astype(int)
    proba[idx] = model.predict_proba(ws.X)
    return grid, proba


def main() -> int:
    """Run the A/B over folds and seeds, print and log the pooled scores."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    runs = [r for r in load_dataset("borealtc") if {"imu", "wheels"} <= set(r.streams)]
    labels = np.array([r.terrain for r in runs], dtype=object)
    ids = np.array([r.run_id for r in runs], dtype=object)
    smoothing = SmoothingConfig()
    rows = []
    t0 = time.perf_counter()
    for seed in args.seeds:
        for fold, (train, test) in enumerate(iter_splits("grouped", labels, ids, seed, 5)):
            stream, segments = concatenated_streams([runs[i] for i in test], ("imu", "wheels"),
                                                    seed * 100 + fold)
            for arm in ARMS:
                ws = make_windows([runs[i] for i in train], arm,
                                  WindowConfig(window_s=WINDOW_S, rate_hz=RATE_HZ))
                y = ws.labels.astype(str)
                model = make_model(ModelConfig(kind="ensemble"), ws.channels, RATE_HZ,
                                   "borealtc", random_state=seed).fit(ws.X, y)
                classes = np.asarray(model.classes_, dtype=object)
                t, proba = stream_proba(model, stream, arm, len(classes))
                names = np.array(list(classes) + [None], dtype=object)
                for name, config in (("raw", SmoothingConfig(dwell_s=None)),
                                     ("default", smoothing)):
                    decided = names[filter_sequence(proba, HOP_S, config)]
                    score = score_stream(segments, t, decided, WINDOW_S)
                    rows.append({"seed": seed, "fold": fold, "signals": arm, "smoothing": name,
                                 "accuracy": score.accuracy,
                                 "median_delay_s": score.median_delay_s,
                                 "n_switches": len(score.delays_s),
                                 "n_decisions": score.n_decisions,
                                 "accuracy_settled": score.accuracy_settled,
                                 "n_settled": score.n_settled,
                                 "delays_s": list(score.delays_s),
                                 "confusion": score.confusion})
                print(f"seed {seed} fold {fold} {arm:8s} raw {rows[-2]['accuracy']:.3f} "
                      f"default {rows[-1]['accuracy']:.3f} "
                      f"(delay {rows[-1]['median_delay_s']:.1f} s)", flush=True)
    frame = pd.DataFrame(rows)
    pooled = {(arm, sm): pool_scores(frame[(frame.signals == arm) & (frame.smoothing == sm)])
              for arm in ARMS for sm in ("raw", "default")}
    print(f"\nheld-out BorealTC streams, seeds {args.seeds}, {time.perf_counter() - t0:.0f} s")
    print("signals   smoothing  accuracy  settled  median delay s  switches")
    for (arm, sm), p in pooled.items():
        print(f"{arm:9s} {sm:9s}  {p['accuracy']:.3f}     {p['accuracy_settled']:.3f}    "
              f"{p['median_delay_s']:.1f}            {p['n_switches']}")
    if not args.no_mlflow:
        with tracked_run("terrain-benchmark", run_name="stream-ekf-channels",
                         params={"seeds": ",".join(map(str, args.seeds)), "window_s": WINDOW_S,
                                 "hop_s": HOP_S, "model": "ensemble"}) as run:
            run.log_metrics({f"{m}_{arm.replace('+', '_')}_{sm}": float(p[m])
                             for (arm, sm), p in pooled.items()
                             for m in ("accuracy", "accuracy_settled", "median_delay_s")})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
