"""Would EKF channels lift the held-out stream accuracy? An offline A/B on the stream protocol.

The model comparison (docs/model_comparison_grid.md) found that the skid-steer EKF's channels
(``all+ekf``) lift the SVM + spectrogram-CNN vote on BorealTC from 0.883 to 0.920 per 2 s
window. Part of that may be history: the filter runs over the whole run, and its slow states
(ICR expansion chi, gyro bias) carry the run's past. On a stream that switches terrain that
memory could cost switching delay. The streaming service does not run the EKF, so this
benchmark measures the effect *offline* on the same held-out streams as
``terrain stream-eval`` (:func:`terrain.serving.evaluation.held_out_folds`, which
:func:`~terrain.serving.evaluation.held_out_streams` uses: the same folds over runs, the same
seeded concatenated streams on a continuous clock):

* per fold, the equal-weight ``ensemble`` (SVM + spectrogram CNN, ``terrain train --model
  ensemble``) is fitted on the training runs' 2 s windows (non-overlapping, or cut every
  ``--train-hop-s``, 0.5 s for the dense recipes of ``terrain stream-eval``), once per arm:
  ``all``, ``all+ekf`` and ``all+windowed-ekf`` (``all`` plus EKF channels computed from
  each window's own samples, the filter started from its prior: no memory older than the
  window, so nothing carries across a switch; the model of ``terrain train --window-ekf``,
  :class:`terrain.models.window_ekf.WindowEKFClassifier`, which computes them itself);
* the held-out stream is aligned once; for ``all+ekf`` the EKF runs causally over the
  *whole stream* (:func:`features.windows.make_windows` on the concatenated run), as an EKF
  inside the service would run across the switches; windows of 2 s end every 0.5 s (the
  service's hop), each classified; a missing window is a prediction-only step;
* both arms go through the same forward filter (the service's default, dwell 10 s, power
  0.5) and are scored by :func:`terrain.serving.evaluation.score_smoothing` (per-decision
  accuracy, settled accuracy, median switching delay).

Both arms share this offline path, so their difference is the EKF channels'. The figures
are not those of ``terrain stream-eval`` (which replays sample by sample through the
service; its ``all-ensemble-dense-window-ekf`` recipe serves the windowed arm).

``--window-cv`` instead asks where the window-CV gain comes from: the spectrogram CNN in the
run-grouped CV of ``terrain compare`` (BorealTC, 2 s windows) on ``all``, on ``all+ekf`` with
the EKF run over each whole run (as ``terrain compare`` does), and on ``all`` plus EKF
channels computed from each window's own samples only (the filter started from its prior at
the window's start, so no state older than the window).

Run: ``python benchmarks/stream_ekf_channels.py [--seeds 0 1 2] [--arms ARM ...]
[--train-hop-s 0.5] [--window-cv] [--no-mlflow]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

from features.windows import WindowConfig, make_windows
from pipelines.arguments import DistinctSeeds, DistinctValues, positive_number, seed_value
from terrain.io.shipped import load_dataset
from terrain.models.compare import Cell, cell_windows
from terrain.models.cv import cross_validate
from terrain.models.registry import ModelConfig, make_model
from terrain.serving.evaluation import held_out_folds, pool_scores, score_smoothing
from terrain.serving.smoothing import SmoothingConfig
from terrain.tracking import require_store, tracked_run

WINDOW_S, HOP_S, RATE_HZ = 2.0, 0.5, 100.0
ARMS = ("all", "all+ekf", "all+windowed-ekf")


def arm_windows(runs, arm: str, config: WindowConfig):
    """Windows of an arm: ``all+ekf`` (EKF over each whole run), else those of ``all``
    (``all+windowed-ekf``: the model appends each window's EKF channels itself,
    :class:`terrain.models.window_ekf.WindowEKFClassifier`).

    Parameters
    ----------
    runs : sequence of Run
    arm : str
        One of :data:`ARMS`.
    config : WindowConfig

    Returns
    -------
    X : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``.
    ws : WindowSet
        The windows' book-keeping (run ids, bounds, labels).
    channels : tuple of str
        Channel names of axis 1 of ``X``.
    """
    ws = make_windows(runs, "all+ekf" if arm == "all+ekf" else "all", config)
    return ws.X, ws, tuple(ws.channels)


def stream_proba(model, stream, arm: str, n_classes: int) -> tuple[np.ndarray, np.ndarray]:
    """Class probabilities of windows ending every ``HOP_S`` on a concatenated stream.

    Parameters
    ----------
    model : classifier
        Fitted on raw windows of ``arm``.
    stream : Run
        Concatenated run.
    arm : str
        One of :data:`ARMS` (``all+ekf``: the EKF runs causally over the whole stream).
    n_classes : int
        Columns of the result.

    Returns
    -------
    t_s : numpy.ndarray
        ``(n,)`` decision times on a regular ``HOP_S`` grid, s.
    proba : numpy.ndarray
        ``(n, n_classes)``; NaN rows where no valid window ends (gaps).
    """
    X, ws, _ = arm_windows([stream], arm, WindowConfig(window_s=WINDOW_S, hop_s=HOP_S,
                                                       rate_hz=RATE_HZ))
    t_end = ws.t_end_s
    grid = np.arange(t_end.min(), t_end.max() + HOP_S / 2, HOP_S)
    proba = np.full((len(grid), n_classes), np.nan)
    idx = np.rint((t_end - grid[0]) / HOP_S).astype(int)
    proba[idx] = model.predict_proba(X)
    return grid, proba


def window_cv(seeds, log: bool) -> int:
    """Spectrogram CNN, run-grouped CV on BorealTC: all / all+ekf (whole run) / windowed EKF."""
    rows = {}
    for arm in ("all", "all+ekf", "all+windowed-ekf"):
        cell = Cell("cnn-spectrogram", "all+ekf" if arm == "all+ekf" else "all", WINDOW_S,
                    "borealtc", seeds[0], "grouped", None)
        ws, labels, groups = cell_windows(cell, 5)[:3]
        config = ModelConfig(kind="cnn-spectrogram", window_ekf=arm == "all+windowed-ekf")
        report = cross_validate(
            lambda s: make_model(config, tuple(ws.channels), ws.rate_hz, "borealtc", s),
            ws.X, labels, groups, ws.run_ids, ws.t_start_s, ws.t_end_s, "grouped", tuple(seeds), 5)
        pooled = report.pooled.mean(numeric_only=True)
        rows[arm] = (float(pooled["accuracy"]), float(pooled["macro_f1"]))
        print(f"{arm:18s} accuracy {rows[arm][0]:.3f}  macro-F1 {rows[arm][1]:.3f}", flush=True)
    if log:
        with tracked_run("terrain-benchmark", run_name="window-cv-ekf-channels",
                         params={"seeds": ",".join(map(str, seeds)), "window_s": WINDOW_S,
                                 "model": "cnn-spectrogram"}) as run:
            run.log_metrics({f"{m}_{arm.replace('+', '_').replace('-', '_')}": v
                             for arm, (acc, f1) in rows.items()
                             for m, v in (("accuracy", acc), ("macro_f1", f1))})
    return 0


def main() -> int:
    """Run the A/B over folds and seeds, print and log the pooled scores."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds,
                        default=[0, 1, 2])
    parser.add_argument("--window-cv", action="store_true",
                        help="where the window-CV gain of the EKF channels comes from "
                             "(spectrogram CNN: all / all+ekf / windowed EKF)")
    parser.add_argument("--arms", nargs="+", action=DistinctValues,
                        choices=ARMS, default=list(ARMS))
    parser.add_argument("--train-hop-s", type=positive_number, default=None,
                        help="hop of the training windows, s (default: the window, 2 s; "
                             "0.5 trains as the dense recipes of terrain stream-eval)")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    if args.window_cv:
        return window_cv(args.seeds, not args.no_mlflow)
    runs = [r for r in load_dataset("borealtc") if {"imu", "wheels"} <= set(r.streams)]
    smoothing = SmoothingConfig()
    rows = []
    t0 = time.perf_counter()
    # every run's training windows of each arm, cut once (a run's windows do not depend on
    # the other runs); each fold trains on those of its training runs
    train_window = WindowConfig(window_s=WINDOW_S, hop_s=args.train_hop_s, rate_hz=RATE_HZ)
    cut = {arm: arm_windows(runs, arm, train_window) for arm in args.arms}
    for seed in args.seeds:
        for fold, train, stream, segments in held_out_folds(runs, ("imu", "wheels"), seed):
            train_ids = [r.run_id for r in train]
            for arm in args.arms:
                X, ws, channels = cut[arm]
                fit_rows = np.isin(ws.run_ids, train_ids)
                config = ModelConfig(kind="ensemble", window_ekf=arm == "all+windowed-ekf")
                model = make_model(config, channels, RATE_HZ,
                                   "borealtc", random_state=seed).fit(
                    X[fit_rows], ws.labels[fit_rows].astype(str))
                classes = np.asarray(model.classes_, dtype=object)
                t, proba = stream_proba(model, stream, arm, len(classes))
                for name, config in (("raw", SmoothingConfig(dwell_s=None)),
                                     ("default", smoothing)):
                    score = score_smoothing(segments, t, proba, classes, config, HOP_S,
                                            WINDOW_S)
                    rows.append({"seed": seed, "fold": fold, "signals": arm, "smoothing": name,
                                 **score.as_row()})
                print(f"seed {seed} fold {fold} {arm:8s} raw {rows[-2]['accuracy']:.3f} "
                      f"default {rows[-1]['accuracy']:.3f} "
                      f"(delay {rows[-1]['median_delay_s']:.1f} s)", flush=True)
    frame = pd.DataFrame(rows)
    pooled = {(arm, sm): pool_scores(frame[(frame.signals == arm) & (frame.smoothing == sm)])
              for arm in args.arms for sm in ("raw", "default")}
    print(f"\nheld-out BorealTC streams, seeds {args.seeds}, {time.perf_counter() - t0:.0f} s")
    print("signals           smoothing  accuracy  settled  median delay s  switches")
    for (arm, sm), p in pooled.items():
        print(f"{arm:17s} {sm:9s}  {p['accuracy']:.3f}     {p['accuracy_settled']:.3f}    "
              f"{p['median_delay_s']:.1f}            {p['n_switches']}")
    if not args.no_mlflow:
        with tracked_run("terrain-benchmark", run_name="stream-ekf-channels",
                         params={"seeds": ",".join(map(str, args.seeds)), "window_s": WINDOW_S,
                                 "hop_s": HOP_S, "model": "ensemble",
                                 "train_hop_s": args.train_hop_s or WINDOW_S,
                                 "arms": ",".join(args.arms)}) as run:
            run.log_metrics({f"{m}_{arm.replace('+', '_').replace('-', '_')}_{sm}": float(p[m])
                             for (arm, sm), p in pooled.items()
                             for m in ("accuracy", "accuracy_settled", "median_delay_s")})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
