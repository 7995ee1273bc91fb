"""Evaluation of streaming terrain decisions, grouped by run.

* :func:`wheel_feature_pipeline` is the wheel-only classifier: window statistics
  (:class:`features.transformers.WindowFeatures`) plus the drive-physics features
  (:class:`features.wheel_physics.WheelPhysicsFeatures`) into the project's SVM.
* :func:`grouped_oof_proba` gives out-of-fold class probabilities with
  ``StratifiedGroupKFold`` grouped by run (:func:`terrain.models.cv.iter_splits`), and
  :func:`smooth_runs` runs the causal forward filter along each run's windows, so per-window
  accuracy can be measured with and without temporal smoothing.
* :func:`concatenated_streams` strings held-out runs of different terrains into one stream
  (seeded segment lengths), and :func:`switching_delays` measures how long the decisions
  take to follow a terrain switch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import pandas as pd
from sklearn.pipeline import FeatureUnion, Pipeline

from features.transformers import WindowFeatures
from features.wheel_physics import WheelPhysicsFeatures
from terrain.errors import ConfigError
from terrain.models.cv import iter_splits
from terrain.models.svm import SVMConfig, make_svm
from terrain.run import TIME, Run
from terrain.streaming.smoothing import ForwardFilter, SmoothingConfig


def wheel_features(channels: tuple[str, ...], rate_hz: float,
                   short_s: float | None = 2.0) -> FeatureUnion:
    """Statistics + physics features of wheel windows (stateless).

    Parameters
    ----------
    channels : tuple of str
        Window channel order (must hold the four wheel channels).
    rate_hz : float
        Window sampling rate, Hz.
    short_s : float or None
        Recent time scale of the physics features, s.

    Returns
    -------
    sklearn.pipeline.FeatureUnion
    """
    return FeatureUnion([("stats", WindowFeatures(channels=channels, rate_hz=rate_hz)),
                         ("physics", WheelPhysicsFeatures(channels=channels, rate_hz=rate_hz,
                                                          short_s=short_s))])


def wheel_feature_pipeline(channels: tuple[str, ...], rate_hz: float,
                           short_s: float | None = 2.0, svm: SVMConfig = SVMConfig(),
                           random_state: int = 0) -> Pipeline:
    """Unfitted ``features -> scaler -> SVC`` pipeline taking raw wheel windows.

    Parameters
    ----------
    channels, rate_hz, short_s
        See :func:`wheel_features`.
    svm : SVMConfig
        Classifier settings (``probability=True`` for serving).
    random_state : int
        Seed of the SVC.

    Returns
    -------
    sklearn.pipeline.Pipeline
    """
    return Pipeline([("features", wheel_features(channels, rate_hz, short_s))]
                    + make_svm(svm, random_state).steps)


def grouped_oof_proba(make_model: Callable[[int], object], F: np.ndarray, labels: np.ndarray,
                      groups: np.ndarray, seed: int, n_splits: int = 5
                      ) -> tuple[np.ndarray, list[str]]:
    """Out-of-fold probabilities with folds grouped by run.

    Parameters
    ----------
    make_model : callable
        ``seed -> unfitted classifier with predict_proba``.
    F : numpy.ndarray
        ``(n_windows, ...)`` model input.
    labels, groups : numpy.ndarray
        ``(n_windows,)`` class labels and split groups (run ids).
    seed : int
        Fold shuffling seed.
    n_splits : int
        Folds.

    Returns
    -------
    proba : numpy.ndarray
        ``(n_windows, n_classes)``.
    classes : list of str
        Sorted class names (column order).
    """
    classes = sorted(np.unique(labels).tolist())
    proba = np.zeros((len(labels), len(classes)))
    for train, test in iter_splits("grouped", labels, groups, seed, n_splits):
        model = make_model(seed)
        model.fit(F[train], labels[train])
        cols = [classes.index(c) for c in model.classes_]
        proba[np.ix_(test, cols)] = model.predict_proba(F[test])
    return proba, classes


def smooth_runs(proba: np.ndarray, run_ids: np.ndarray, t_s: np.ndarray, hop_s: float,
                config: SmoothingConfig) -> np.ndarray:
    """Causal forward filtering of window probabilities along each run.

    Parameters
    ----------
    proba : numpy.ndarray
        ``(n_windows, n_classes)``.
    run_ids, t_s : numpy.ndarray
        ``(n_windows,)`` run of each window and its time, s (windows are ordered by it).
    hop_s : float
        Time between consecutive windows, s.
    config : SmoothingConfig

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)`` decided class index of each window.
    """
    out = np.zeros(len(proba), dtype=int)
    for run in np.unique(run_ids):
        idx = np.flatnonzero(run_ids == run)
        idx = idx[np.argsort(t_s[idx], kind="stable")]
        filt = ForwardFilter(proba.shape[1], hop_s, config)
        for i in idx:
            out[i] = filt.update(proba[i])[0]
    return out


@dataclass(frozen=True)
class Segment:
    """One piece of a concatenated stream.

    Parameters
    ----------
    run_id : str
        Source run.
    terrain : str
        Its label.
    t_from_s : float
        Start of the piece on the run's clock, s.
    t_offset_s : float
        Shift added to the run's timestamps to place the piece on the stream clock, s.
    duration_s : float
        Length of the piece, s.
    """

    run_id: str
    terrain: str
    t_from_s: float
    t_offset_s: float
    duration_s: float


def concatenated_streams(runs: Sequence[Run], streams: Sequence[str], seed: int,
                         min_s: float = 30.0, max_s: float = 120.0, gap_s: float = 0.1
                         ) -> tuple[Run, list[Segment]]:
    """String runs of changing terrain into one long run (seeded).

    Runs are taken in a seeded random order, each time choosing a run whose terrain differs
    from the previous piece's; each piece is a random stretch of ``min_s``-``max_s`` seconds
    (capped at the run's length; every run is used once).

    Parameters
    ----------
    runs : sequence of Run
        Candidate runs (held out of training); those lacking a stream are skipped.
    streams : sequence of str
        Streams to keep.
    seed : int
        Seed of the order and piece lengths.
    min_s, max_s : float
        Piece length bounds, s.
    gap_s : float
        Time between the end of a piece and the first sample of the next, s.

    Returns
    -------
    run : Run
        The concatenated run (terrain ``None``; ``meta["segments"]`` lists the pieces).
    segments : list of Segment

    Raises
    ------
    ConfigError
        Fewer than two terrains among the usable runs.
    """
    rng = np.random.default_rng(seed)
    pool = [r for r in runs if all(s in r.streams for s in streams)]
    if len({r.terrain for r in pool}) < 2:
        raise ConfigError("a concatenated stream needs runs of at least two terrains")
    order = list(rng.permutation(len(pool)))
    parts: dict[str, list[pd.DataFrame]] = {s: [] for s in streams}
    segments: list[Segment] = []
    clock = 0.0
    while order:
        prev = segments[-1].terrain if segments else None
        pick = next((k for k in order if pool[k].terrain != prev), order[0])
        order.remove(pick)
        run = pool[pick]
        t_lo = max(run.streams[s][TIME].iloc[0] for s in streams)
        t_hi = min(run.streams[s][TIME].iloc[-1] for s in streams)
        length = min(float(rng.uniform(min_s, max_s)), t_hi - t_lo)
        if length < min(min_s, 10.0):
            continue
        start = t_lo + float(rng.uniform(0.0, t_hi - t_lo - length))
        offset = clock - start
        for s in streams:
            f = run.streams[s]
            sel = f[(f[TIME] >= start) & (f[TIME] < start + length)]
            parts[s].append(sel.assign(**{TIME: sel[TIME] + offset}))
        segments.append(Segment(run.run_id, str(run.terrain), start, offset, length))
        clock += length + gap_s
    frames = {s: pd.concat(p, ignore_index=True) for s, p in parts.items()}
    return Run("concatenated", "concatenated", None, frames,
               meta={"segments": [s.__dict__ for s in segments]}), segments


def truth_at(segments: Sequence[Segment], t_s: np.ndarray) -> np.ndarray:
    """True terrain at stream times (``None`` between pieces).

    Parameters
    ----------
    segments : sequence of Segment
    t_s : numpy.ndarray
        ``(n,)`` stream times, s.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` object array of labels.
    """
    out = np.full(len(t_s), None, dtype=object)
    for s in segments:
        a = s.t_from_s + s.t_offset_s
        out[(t_s >= a) & (t_s < a + s.duration_s)] = s.terrain
    return out


def switching_delays(segments: Sequence[Segment], t_s: np.ndarray,
                     decided: np.ndarray) -> np.ndarray:
    """Delay from each terrain switch until the decisions first name the new terrain, s.

    Parameters
    ----------
    segments : sequence of Segment
        Pieces in stream order.
    t_s : numpy.ndarray
        ``(n,)`` decision times, s (increasing).
    decided : numpy.ndarray
        ``(n,)`` decided terrain of each decision.

    Returns
    -------
    numpy.ndarray
        ``(n_switches,)`` delays, s; ``inf`` when the piece ended before the new terrain was
        ever decided.
    """
    delays = []
    for prev, seg in zip(segments[:-1], segments[1:]):
        if seg.terrain == prev.terrain:
            continue
        a = seg.t_from_s + seg.t_offset_s
        sel = (t_s >= a) & (t_s < a + seg.duration_s) & (decided == seg.terrain)
        delays.append(float(t_s[sel][0] - a) if sel.any() else np.inf)
    return np.asarray(delays)
