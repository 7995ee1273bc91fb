"""Two window lengths in one decision: does averaging a 1 s and a 2 s classifier lift the
held-out streams?

On the held-out streams the 1 s recipe (``all-ensemble-dense-no-speed-1s``) follows a
switch sooner (median delay 1.5 s against 2.2 s) and the 2 s recipe
(``all-ensemble-dense-no-speed``) is right more often on settled windows (0.936 against
0.931, docs/streaming.md). A model that takes the 2 s window and averages its 2 s classifier
with a 1 s classifier on the window's last second would be servable unchanged (one window
per decision). One variant, fixed before measuring: equal weights, the service's default
forward filter.

Replays the held-out concatenated streams of ``terrain stream-eval`` (same folds over runs,
same seeded streams, :func:`terrain.serving.evaluation.held_out_folds`). Per fold both
recipes are fitted on the training runs and replayed unsmoothed; at every decision time of
the 2 s classifier the two window probabilities are averaged (the 1 s window is the last
second of the 2 s window: both end at the decision time) and the forward filter decides.
The two recipes alone are scored on the same replays, so their rows reproduce
``terrain stream-eval``.

``--members SHORT LONG`` averages two other recipes of :data:`RECIPES` the same way, at the
decision times of the second (give the one with the longer window second): e.g. the 1 s
all-signal ensemble with the wheel-only model (``--members
all-ensemble-dense-no-speed-1s-run-balanced wheels``), whose drive-physics features on 4 s of
wheel history are evidence the all-signal members do not compute.

Run: ``python benchmarks/stream_multiscale.py [--seeds 0 1 2] [--members SHORT LONG]
[--no-mlflow]`` (about 20 min on a 2-core machine; logged to MLflow, experiment
``terrain-benchmark``).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

from pipelines.arguments import DistinctSeeds, seed_value
from terrain.io.shipped import load_dataset
from terrain.serving.evaluation import (encode_stream_scores, held_out_folds, pool_scores,
                                        raw_decisions, score_smoothing, seed_accuracies)
from terrain.serving.recipes import RECIPES, fit_stream_model
from terrain.serving.smoothing import SmoothingConfig
from terrain.tracking import require_store, tracked_run

HOP_S = 0.5
SHORT, LONG = "all-ensemble-dense-no-speed-1s", "all-ensemble-dense-no-speed"


def at_times(t_from: np.ndarray, proba: np.ndarray, t_to: np.ndarray) -> np.ndarray:
    """Rows of ``proba`` (decided at ``t_from``) at the times ``t_to`` (NaN where none).

    Parameters
    ----------
    t_from : numpy.ndarray
        ``(n,)`` increasing decision times, s.
    proba : numpy.ndarray
        ``(n, n_classes)`` window probabilities.
    t_to : numpy.ndarray
        ``(m,)`` decision times wanted, s (the same hop grid, matched to 1 ms).

    Returns
    -------
    numpy.ndarray
        ``(m, n_classes)``.
    """
    i = np.clip(np.searchsorted(t_from, t_to - 1e-3), 0, len(t_from) - 1)
    out = proba[i].copy()
    out[np.abs(t_from[i] - t_to) > 1e-3] = np.nan
    return out


def main() -> int:
    ap = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds, default=[0, 1, 2])
    ap.add_argument("--members", nargs=2, default=[SHORT, LONG], choices=sorted(RECIPES),
                    metavar="RECIPE", help="the two recipes averaged; the second's decision "
                    "times are used (default: %(default)s)")
    ap.add_argument("--no-mlflow", action="store_true")
    args = ap.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    short, long = args.members
    if short == long:
        ap.error(f"--members: two different recipes, got {short} twice")
    runs = load_dataset("borealtc")
    config = SmoothingConfig()
    start = time.perf_counter()
    rows = []
    for seed in args.seeds:
        for fold, train, stream, segments in held_out_folds(runs, ("imu", "wheels"), seed,
                                                            progress=True):
            replays = {}
            for kind in (short, long):
                model = fit_stream_model(RECIPES[kind], train, seed)
                replays[kind] = (*raw_decisions(model, stream, HOP_S), model.classes)
            (t1, p1, c1), (t2, p2, c2) = replays[short], replays[long]
            if list(c1) != list(c2):
                raise RuntimeError(f"class orders differ: {c1} vs {c2}")
            both = 0.5 * (p2 + at_times(t1, p1, t2))
            w1, w2 = RECIPES[short].window_s, RECIPES[long].window_s
            arms = {short: (t1, p1, w1), long: (t2, p2, w2), "average": (t2, both, max(w1, w2))}
            for arm, (t, p, window_s) in arms.items():
                score = score_smoothing(segments, t, p, c1, config, HOP_S, window_s)
                rows.append({"seed": seed, "fold": fold, "arm": arm, **score.as_row()})
    frame = pd.DataFrame(rows)
    metrics = {}
    print(f"held-out BorealTC streams, seeds {args.seeds}, forward filter (default), "
          f"{time.perf_counter() - start:.0f} s")
    for arm, g in frame.groupby("arm", sort=False):
        p = pool_scores(g)
        per_seed = seed_accuracies(g).values()
        print(f"  {arm:32s} per decision {p['accuracy']:.4f}  settled "
              f"{p['accuracy_settled']:.4f}  median delay {p['median_delay_s']:.2f} s  "
              f"per seed {' / '.join(f'{a:.3f}' for a in per_seed)}")
        metrics.update({f"{arm}_accuracy": p["accuracy"],
                        f"{arm}_accuracy_settled": p["accuracy_settled"],
                        f"{arm}_median_delay_s": p["median_delay_s"]})
    if not args.no_mlflow:
        with tracked_run("terrain-benchmark", run_name="stream-multiscale",
                         params={"short": short, "long": long,
                                 "seeds": ",".join(map(str, args.seeds))}) as run:
            run.log_metrics(metrics)
            # delays and confusion as JSON: read_stream_scores reads the table back
            run.log_table(encode_stream_scores(frame), "stream_multiscale_folds.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
