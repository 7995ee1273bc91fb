"""Evaluation of streaming terrain decisions, grouped by run.

The models evaluated are those of :mod:`terrain.serving.recipes`
(:class:`~terrain.serving.recipes.ModelRecipe`,
:data:`RECIPES`, :func:`fit_stream_model`); :func:`window_cv` scores one run-grouped.

* :func:`grouped_oof_proba` gives out-of-fold class probabilities with
  ``StratifiedGroupKFold`` grouped by run (:func:`terrain.models.cv.iter_splits`), and
  :func:`smooth_runs` runs the causal forward filter along each run's windows, so per-window
  accuracy can be measured with and without temporal smoothing.
* :func:`concatenated_streams` strings held-out runs of different terrains into one stream
  (seeded segment lengths), and :func:`switching_delays` measures how long the decisions
  take to follow a terrain switch.
"""

from __future__ import annotations

import ast
import json
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Callable, Iterator, Mapping, Sequence

import numpy as np
import pandas as pd

from features.windows import WindowConfig, make_windows, runs_track_m
from terrain.errors import (ConfigError, DataFormatError, config_integer, config_positive,
                            duplicated, first_items, refuse_mixed_types)
from terrain.models.cv import iter_splits
from terrain.run import TIME, Run
from terrain.serving.model import StreamModel
from terrain.serving.recipes import (ModelRecipe, fit_stream_model, recipe_classifier,
                                     recipe_features, run_balanced_weights)
from terrain.serving.replay import replay_run
from terrain.serving.service import UNCLASSIFIED_FLAGS, StreamConfig, StreamService
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig
from terrain.serving.targets import CataloguePeakTargets

#: decided class index of a window without a decision (:func:`smooth_runs`,
#: :func:`filter_sequence`: no window with finite probabilities yet); its callers index
#: ``classes + [None]`` with it, so it is scored as stream-eval scores an unclassified window
NO_DECISION = -1


def grouped_oof_proba(make_model: Callable[[int], object], F: np.ndarray, labels: np.ndarray,
                      groups: np.ndarray, seed: int, n_splits: int = 5,
                      run_balanced: bool = False) -> tuple[np.ndarray, list[str]]:
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
    run_balanced : bool
        Fit with :func:`run_balanced_weights` of the training fold (``sample_weight``).

    Returns
    -------
    proba : numpy.ndarray
        ``(n_windows, n_classes)``.
    classes : list of str
        Sorted class names (column order).

    Raises
    ------
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``labels`` or
        ``groups`` (:func:`terrain.errors.refuse_mixed_types`).
    """
    for name, values in (("labels", labels), ("groups", groups)):
        refuse_mixed_types("grouped_oof_proba", name, values)   # (NumPy's bare TypeError)
    classes = sorted(np.unique(labels).tolist())
    proba = np.zeros((len(labels), len(classes)))
    for train, test in iter_splits("grouped", labels, groups, seed, n_splits):
        model = make_model(seed)
        weights = ({"sample_weight": run_balanced_weights(labels[train], groups[train])}
                   if run_balanced else {})
        model.fit(F[train], labels[train], **weights)
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
        Time between consecutive windows, s. Windows a run lacks (``t_s`` more than one
        hop apart, e.g. around a timestamp gap) are the filter's prediction-only steps
        (:meth:`~terrain.serving.smoothing.ForwardFilter.skip`), as in the live service.
    config : SmoothingConfig

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)`` decided class index of each window; :data:`NO_DECISION` (-1) for
        the windows of a run before its first window with finite probabilities (a NaN or
        inf one is no evidence: :meth:`~terrain.serving.smoothing.ForwardFilter.update`).

    Raises
    ------
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``run_ids``
        (:func:`terrain.errors.refuse_mixed_types`).
    """
    refuse_mixed_types("smooth_runs", "run_ids", run_ids)   # (NumPy's bare TypeError)
    out = np.full(len(proba), NO_DECISION)
    for run in np.unique(run_ids):
        idx = np.flatnonzero(run_ids == run)
        idx = idx[np.argsort(t_s[idx], kind="stable")]
        out[idx] = filter_sequence(proba[idx], hop_s, config, t_s[idx])
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
                         min_s: float = 30.0, max_s: float = 120.0, gap_s: float = 0.0
                         ) -> tuple[Run, list[Segment]]:
    """String runs of changing terrain into one long run (seeded).

    Runs are taken in a seeded random order, each time choosing the first run whose terrain
    differs from the previous piece's and after which the runs left can still alternate, so
    the terrain changes at every switch wherever the runs allow it; each piece is a random
    stretch of ``min_s``-``max_s`` seconds (capped at the run's length). Every run is used
    once, except a run whose streams overlap for less than ``min(min_s, 10 s)`` (one whose
    stream holds no sample included): it is left out and named in ``meta["skipped_runs"]``
    (BorealTC's ASPHALT/02, 9.5 s).

    Parameters
    ----------
    runs : sequence of Run
        Candidate runs (held out of training); those lacking a stream are skipped.
    streams : sequence of str
        Streams to keep.
    seed : int
        Seed of the order and piece lengths (>= 0).
    min_s, max_s : float
        Piece length bounds, s.
    gap_s : float
        Time added between the end of a piece and the start of the next, s. With the default
        0 the clock runs on as it would for a robot driving from one terrain onto the next:
        the step across a switch is shorter than two of each stream's usual steps, so the
        service's gap rule (3 usual steps) does not fire. A positive ``gap_s`` adds a
        dropout at every switch (0.1 s was used before: on the 100 Hz IMU that is a gap, and
        every window holding it is left unclassified).

    Returns
    -------
    run : Run
        The concatenated run (terrain ``None``; ``meta["segments"]`` lists the pieces,
        ``meta["skipped_runs"]`` the ids of the runs too short for a piece).
    segments : list of Segment

    Raises
    ------
    ConfigError
        Fewer than two terrains among the usable runs (those holding ``streams``, their
        streams overlapping for at least ``min(min_s, 10 s)``); the message names the runs
        too short and their lengths. ``min_s`` or ``max_s`` not a finite number > 0,
        ``max_s`` below ``min_s``, or ``gap_s`` not a finite number >= 0 (a negative gap
        would lay each piece over the end of the one before), or ``seed`` not an integer
        >= 0 (``None`` would string an unseeded stream, another at every call). ``streams``
        empty, a bare name (``"wheels"`` would be read as the streams ``w``, ``h``...) or
        naming a stream twice (each piece would be laid in twice, the clock stepping back).
    """
    if isinstance(streams, (str, bytes)) or not len(streams):
        raise ConfigError("concatenated_streams.streams must be a sequence of stream names, "
                          f"got {'the text ' if isinstance(streams, (str, bytes)) else ''}"
                          f"{streams!r:.60}" + ("" if len(streams) else " (no stream)"))
    twice = duplicated(list(streams))
    if twice:
        raise ConfigError(f"concatenated_streams.streams names {', '.join(map(repr, twice))} "
                          "more than once; name each stream once")
    config_integer("concatenated_streams.seed", seed, 0)
    config_positive("concatenated_streams", min_s=min_s, max_s=max_s)
    config_positive("concatenated_streams", allow_zero=True, gap_s=gap_s)
    if max_s < min_s:
        raise ConfigError(f"concatenated_streams.max_s must be >= min_s ({min_s!r} s), "
                          f"got {max_s!r}")
    rng = np.random.default_rng(seed)
    pool = [r for r in runs if all(s in r.streams for s in streams)]
    if len({r.terrain for r in pool}) < 2:
        raise ConfigError("a concatenated stream needs runs of at least two terrains")
    # each run's span with every stream present; a run shorter than a piece is skipped
    # (one whose stream holds no sample spans nothing)
    bounds = [(max(r.streams[s][TIME].iloc[0] for s in streams),
               min(r.streams[s][TIME].iloc[-1] for s in streams))
              if all(len(r.streams[s]) for s in streams) else (0.0, 0.0) for r in pool]
    shortest_s = min(min_s, 10.0)
    kept = {k for k, (lo, hi) in enumerate(bounds) if hi - lo >= shortest_s}
    if len({pool[k].terrain for k in kept}) < 2:
        short = [f"{r.run_id} ({hi - lo:.3g} s)" for k, (r, (lo, hi)) in
                 enumerate(zip(pool, bounds)) if k not in kept]
        raise ConfigError(
            f"a concatenated stream needs runs of at least two terrains at least "
            f"{shortest_s:g} s long (min(min_s={min_s:g}, 10 s)); of the {len(pool)} runs "
            f"given, {len(short)} are shorter: {first_items(short, word='run')}")
    order = list(rng.permutation(len(pool)))
    parts: dict[str, list[pd.DataFrame]] = {s: [] for s in streams}
    segments: list[Segment] = []
    skipped: list[str] = []
    clock = 0.0
    while order:
        prev = segments[-1].terrain if segments else None
        others = [k for k in order if pool[k].terrain != prev]
        left = [k for k in order if k in kept]
        # the first run in the seeded order whose terrain differs from the previous piece's
        # and leaves runs that can still alternate; a plain first pick could strand runs of
        # one terrain at the end, side by side, when an order without them existed
        pick = next((k for k in others if k not in kept or _can_alternate(
            pool, [j for j in left if j != k], pool[k].terrain)), None)
        if pick is None:   # they cannot alternate: the most frequent other terrain (fewest joins)
            count = Counter(pool[j].terrain for j in left)
            pick = max(others, key=lambda k: count[pool[k].terrain], default=order[0])
        order.remove(pick)
        run = pool[pick]
        t_lo, t_hi = bounds[pick]
        length = min(float(rng.uniform(min_s, max_s)), t_hi - t_lo)
        if length < shortest_s:
            skipped.append(run.run_id)
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
               meta={"segments": [s.__dict__ for s in segments],
                     "skipped_runs": skipped}), segments


def _can_alternate(pool: Sequence[Run], left: Sequence[int], prev: str) -> bool:
    """Whether the runs ``left`` can follow a piece of terrain ``prev`` with the terrain
    changing at every switch.

    Parameters
    ----------
    pool : sequence of Run
        Candidate runs.
    left : sequence of int
        Indices into ``pool`` of the runs still to place.
    prev : str
        Terrain of the piece they follow.

    Returns
    -------
    bool
        True when no terrain has more than half the runs (rounded up), and ``prev`` not
        more than half rounded down (it cannot take the first place).
    """
    n = len(left)
    counts = Counter(str(pool[k].terrain) for k in left)
    return all(c <= ((n // 2) if t == prev else (n + 1) // 2) for t, c in counts.items())


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
        ``(n_switches,)`` delays, s; ``inf`` when the new terrain was not decided before it
        ended (its piece and any pieces of the same terrain right after it, which are no
        switch: the robot is still on the terrain it switched to).
    """
    delays = []
    for i in range(1, len(segments)):
        seg = segments[i]
        if seg.terrain == segments[i - 1].terrain:
            continue
        a = seg.t_from_s + seg.t_offset_s
        inside = np.zeros(len(t_s), dtype=bool)
        for piece in segments[i:]:
            if piece.terrain != seg.terrain:
                break
            start = piece.t_from_s + piece.t_offset_s
            inside |= (t_s >= start) & (t_s < start + piece.duration_s)
        sel = inside & (decided == seg.terrain)
        delays.append(float(t_s[sel][0] - a) if sel.any() else np.inf)
    return np.asarray(delays)


def raw_decisions(model: StreamModel, run: Run, hop_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Replay ``run`` through an unsmoothed service; per-decision classifier probabilities.

    Parameters
    ----------
    model : StreamModel
    run : Run
    hop_s : float
        Decision hop, s.

    Returns
    -------
    t_s : numpy.ndarray
        ``(n,)`` decision times, s.
    proba : numpy.ndarray
        ``(n, n_classes)`` classifier probabilities (``n`` 0 for a run shorter than one
        window); NaN rows where the service did not
        classify the window (:data:`~terrain.serving.service.UNCLASSIFIED_FLAGS`: a gap, too
        short, or a units rule), which the filter treats as prediction-only steps, as the
        live service does (the unsmoothed service reports uniform probabilities there).
    """
    svc = StreamService(model, CataloguePeakTargets(model.classes),
                        StreamConfig(hop_s=hop_s, smoothing=SmoothingConfig(dwell_s=None)))
    decisions = replay_run(svc, run)
    t = np.array([d.t_s for d in decisions])
    proba = np.array([d.proba for d in decisions]).reshape(len(decisions), len(model.classes))
    invalid = np.array([not UNCLASSIFIED_FLAGS.isdisjoint(d.flags.split("|"))
                        for d in decisions], dtype=bool)
    proba[invalid] = np.nan
    return t, proba


def filter_sequence(proba: np.ndarray, hop_s: float, config: SmoothingConfig,
                    t_s: np.ndarray | None = None) -> np.ndarray:
    """Decided class index of each step of one stream (:data:`NO_DECISION` before any valid
    window).

    Parameters
    ----------
    proba : numpy.ndarray
        ``(n, n_classes)``; NaN rows are invalid windows.
    hop_s : float
        Step, s.
    config : SmoothingConfig
    t_s : numpy.ndarray or None
        ``(n,)`` decision times, s. Hops missing between two of them (the decisions a
        service skipped in a silent stretch longer than its ``max_backlog_s``) are the
        filter's prediction-only steps (:meth:`~terrain.serving.smoothing.ForwardFilter.skip`),
        as in the live service; None: the decisions are one hop apart.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` int.
    """
    filt = ForwardFilter(proba.shape[1], hop_s, config)
    out = np.full(len(proba), NO_DECISION)
    # hops without a decision before each one (0 for decisions one hop apart)
    missing = np.zeros(len(proba), dtype=int) if t_s is None or not len(proba) else \
        np.maximum(np.rint(np.diff(t_s, prepend=t_s[0]) / hop_s) - 1, 0).astype(int)
    for i, q in enumerate(proba):
        filt.skip(int(missing[i]))
        decided = filt.update(q)[0]     # a non-finite row is no evidence (update)
        out[i] = NO_DECISION if decided is None else decided
    return out


def score_smoothing(segments: Sequence[Segment], t_s: np.ndarray, proba: np.ndarray,
                    classes: Sequence[str], config: SmoothingConfig, hop_s: float,
                    window_s: float = 0.0) -> "StreamScore":
    """Score one smoothing setting on a replayed stream's raw window probabilities.

    :func:`filter_sequence` decides (with the prediction steps of the hops missing between
    decision times, as the live service takes them), :func:`score_stream` scores.

    Parameters
    ----------
    segments : sequence of Segment
        Pieces of the stream.
    t_s : numpy.ndarray
        ``(n,)`` decision times, s.
    proba : numpy.ndarray
        ``(n, n_classes)`` raw window probabilities (NaN rows: invalid windows), columns in
        the order of ``classes``.
    classes : sequence of str
        Class names.
    config : SmoothingConfig
    hop_s : float
        Step between decisions, s.
    window_s : float
        History a decision rests on, s (:func:`score_stream`).

    Returns
    -------
    StreamScore
    """
    names = np.array(list(classes) + [None], dtype=object)
    decided = filter_sequence(proba, hop_s, config, np.asarray(t_s, dtype=float))
    return score_stream(segments, t_s, names[decided], window_s)


@dataclass(frozen=True)
class StreamScore:
    """Score of decisions on a concatenated stream.

    Parameters
    ----------
    accuracy : float
        Share of decisions (inside a piece) naming the piece's terrain.
    delays_s : tuple of float
        Switching delay of every terrain switch, s (``inf``: never followed).
    n_decisions : int
        Decisions scored.
    accuracy_settled : float
        Accuracy of the decisions whose whole window (``window_s`` of history) lies inside
        one piece, i.e. away from the switch transients (NaN when there are none).
    n_settled : int
        Decisions in ``accuracy_settled``.
    confusion : Mapping[str, Mapping[str, int]]
        True terrain -> decided terrain (``"none"`` before any decision) -> decisions.
    """

    accuracy: float
    delays_s: tuple[float, ...]
    n_decisions: int
    accuracy_settled: float = float("nan")
    n_settled: int = 0
    confusion: Mapping[str, Mapping[str, int]] = field(
        default_factory=lambda: MappingProxyType({}))

    @property
    def median_delay_s(self) -> float:
        """Median switching delay, s."""
        return float(np.median(self.delays_s)) if self.delays_s else float("nan")

    def as_row(self) -> dict:
        """The score as one table row (the columns :func:`pool_scores` reads).

        Returns
        -------
        dict
            ``accuracy, median_delay_s`` (s), ``n_switches, n_decisions, accuracy_settled,
            n_settled, delays_s`` (list, s) and ``confusion``.
        """
        return {"accuracy": self.accuracy, "median_delay_s": self.median_delay_s,
                "n_switches": len(self.delays_s), "n_decisions": self.n_decisions,
                "accuracy_settled": self.accuracy_settled, "n_settled": self.n_settled,
                "delays_s": [float(d) for d in self.delays_s],
                "confusion": {str(t): {str(d): int(n) for d, n in row.items()}
                              for t, row in self.confusion.items()}}


def score_stream(segments: Sequence[Segment], t_s: np.ndarray, decided: np.ndarray,
                 window_s: float = 0.0) -> StreamScore:
    """Accuracy, settled accuracy, confusion and switching delays of stream decisions.

    Parameters
    ----------
    segments : sequence of Segment
    t_s : numpy.ndarray
        ``(n,)`` decision times, s.
    decided : numpy.ndarray
        ``(n,)`` decided terrain names (object; ``None`` before any decision).
    window_s : float
        History a decision rests on, s: a decision is settled when the terrain at
        ``t - window_s`` is the terrain at ``t`` (pieces, 30-120 s, outlast any window, so
        its history lies on one terrain; two adjacent pieces of one terrain count as one).

    Returns
    -------
    StreamScore

    Raises
    ------
    ConfigError
        ``window_s`` not a finite number >= 0 (a NaN one would leave no decision settled,
        silently).
    """
    config_positive("score_stream", allow_zero=True, window_s=window_s)
    truth = truth_at(segments, t_s)
    sel = truth != None  # noqa: E711 (element-wise)
    ok = decided == truth
    acc = float(ok[sel].mean()) if sel.any() else float("nan")
    settled = sel & (truth_at(segments, t_s - window_s) == truth)
    acc_settled = float(ok[settled].mean()) if settled.any() else float("nan")
    confusion: dict[str, dict[str, int]] = {}
    for true, got in zip(truth[sel], decided[sel]):
        row = confusion.setdefault(str(true), {})
        key = "none" if got is None else str(got)
        row[key] = row.get(key, 0) + 1
    return StreamScore(acc, tuple(switching_delays(segments, t_s, decided)), int(sel.sum()),
                       acc_settled, int(settled.sum()), confusion)


def runs_holding(runs: Sequence[Run], streams: Sequence[str]) -> list[Run]:
    """The runs holding every one of ``streams``: the split units of the held-out streams.

    Parameters
    ----------
    runs : sequence of Run
        Labelled runs.
    streams : sequence of str
        Stream names (``imu``, ``wheels``; :func:`recipe_stream_names`).

    Returns
    -------
    list of Run
        The runs holding them, in the given order.
    """
    return [r for r in runs if all(s in r.streams for s in streams)]


def recipe_stream_names(recipe: ModelRecipe) -> tuple[str, ...]:
    """Streams every run of a recipe's held-out streams must hold.

    Parameters
    ----------
    recipe : ModelRecipe
        The streaming recipe.

    Returns
    -------
    tuple of str
        ``("wheels",)`` for a wheel-only recipe, else ``("imu", "wheels")``.
    """
    return ("imu", "wheels") if recipe.signals != "wheels" else ("wheels",)


def model_stream_names(model: StreamModel) -> tuple[str, ...]:
    """Streams a fitted model reads (:attr:`StreamService.needed_streams` under the default
    stream layout), for a model read from a folder whose recipe is not known.

    Parameters
    ----------
    model : StreamModel
        The fitted model.

    Returns
    -------
    tuple of str
        E.g. ``("wheels",)`` for a wheel-only model, ``("imu", "wheels")`` for all signals.

    Raises
    ------
    ConfigError
        A channel of the model in none of the default streams.
    """
    return StreamService(model, CataloguePeakTargets(model.classes)).needed_streams


def held_out_folds(runs: Sequence[Run], streams: Sequence[str], seed: int,
                   n_splits: int = 5, switch_gap_s: float = 0.0, progress: bool = False
                   ) -> Iterator[tuple[int, list[Run], Run, list[Segment]]]:
    """The folds of the held-out stream protocol: training runs and the held-out stream.

    The runs holding every one of ``streams`` are split run-grouped
    (:func:`terrain.models.cv.iter_splits`, ``grouped``); the test runs of fold ``f`` are
    concatenated into one stream seeded ``100 seed + f`` (:func:`concatenated_streams`).
    :func:`held_out_streams` and the offline benchmarks that score the same streams use it.

    Parameters
    ----------
    runs : sequence of Run
        Labelled runs.
    streams : sequence of str
        Streams every used run must hold (and the stream keeps).
    seed : int
        Seed of the folds and the streams.
    n_splits : int
        Folds.
    switch_gap_s : float
        Dropout added at every switch of the stream, s (``gap_s`` of
        :func:`concatenated_streams`).
    progress : bool
        Show a progress bar over the folds (tqdm, on stderr): the work done per fold by the
        caller (fitting, replaying) is what takes the time.

    Yields
    ------
    fold : int
    train : list of Run
        The fold's training runs.
    stream : Run
        Its held-out runs concatenated.
    segments : list of Segment
        The pieces of ``stream``.
    """
    usable = runs_holding(runs, streams)
    labels = np.array([r.terrain for r in usable], dtype=object)
    ids = np.array([r.run_id for r in usable], dtype=object)
    splits = enumerate(iter_splits("grouped", labels, ids, seed, n_splits))
    if progress:
        from tqdm.auto import tqdm
        splits = tqdm(splits, total=n_splits, desc=f"held-out streams, seed {seed}",
                      unit="fold")
    for fold, (train, test) in splits:
        stream, segments = concatenated_streams([usable[i] for i in test], streams,
                                                seed * 100 + fold, gap_s=switch_gap_s)
        yield fold, [usable[i] for i in train], stream, segments


def held_out_streams(runs: Sequence[Run], recipe: ModelRecipe, seed: int,
                     smoothings: Mapping[str, SmoothingConfig], hop_s: float = 0.5,
                     n_splits: int = 5, switch_gap_s: float = 0.0,
                     progress: bool = False) -> pd.DataFrame:
    """Train on all but one fold of the runs, replay the held-out fold as one concatenated
    stream (4/5 and a fifth with the default five folds).

    Runs are split by ``StratifiedGroupKFold`` over runs (one group per run, seeded); each
    fold's test runs are strung together by :func:`concatenated_streams` (switches every
    30-120 s) and replayed sample by sample through the service.

    Parameters
    ----------
    runs : sequence of Run
        Labelled runs.
    recipe : ModelRecipe
    seed : int
        Seed of the folds, the stream and the classifier.
    smoothings : Mapping[str, SmoothingConfig]
        Named smoothing settings to score on the same replayed decisions.
    hop_s : float
        Decision hop, s.
    n_splits : int
        Folds.
    switch_gap_s : float
        Dropout added at every switch of the stream, s (``gap_s`` of
        :func:`concatenated_streams`; default none, a continuous clock).
    progress : bool
        Show a progress bar over the folds (tqdm, on stderr).

    Returns
    -------
    pandas.DataFrame
        One row per fold and smoothing: ``fold, smoothing, accuracy, median_delay_s,
        n_switches, n_decisions, accuracy_settled, n_settled, delays_s, confusion`` (see
        :class:`StreamScore`).
    """
    need = recipe_stream_names(recipe)
    rows = []
    for fold, train, stream, segments in held_out_folds(runs, need, seed, n_splits,
                                                        switch_gap_s, progress):
        model = fit_stream_model(recipe, train, seed)
        t, proba = raw_decisions(model, stream, hop_s)
        for name, config in smoothings.items():
            score = score_smoothing(segments, t, proba, model.classes, config, hop_s,
                                    recipe.window_s)
            rows.append({"fold": fold, "smoothing": name, **score.as_row()})
    return pd.DataFrame(rows)


#: A number as the score tables write it: plain, ``np.float64(...)``-wrapped (tables
#: written before :func:`encode_stream_scores`), ``inf`` or JSON's ``Infinity``.
_NUMBER = re.compile(r"[-+]?(?:Infinity|inf|(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")


def encode_stream_scores(frame: pd.DataFrame) -> pd.DataFrame:
    """Score rows (:func:`held_out_streams`, :meth:`StreamScore.as_row`) ready for a CSV.

    The list and mapping columns, ``delays_s`` and ``confusion``, become JSON text, so
    :func:`read_stream_scores` reads the written table back for :func:`pool_scores`.

    Parameters
    ----------
    frame : pandas.DataFrame
        Score rows; other columns are kept as they are.

    Returns
    -------
    pandas.DataFrame
        A copy with those two columns as JSON strings.
    """
    out = frame.copy()
    for column in ("delays_s", "confusion"):
        if column in out:
            out[column] = [json.dumps(v) for v in out[column]]
    return out


def read_stream_scores(path: str | Path) -> pd.DataFrame:
    """Read a CSV of score rows (:func:`encode_stream_scores`; ``terrain stream-eval``'s
    ``held_out_streams_<kind>.csv``, also those logged before that function existed).

    Parameters
    ----------
    path : str or pathlib.Path
        CSV file.

    Returns
    -------
    pandas.DataFrame
        The rows, ``delays_s`` as lists of floats (s) and ``confusion`` as nested dicts, as
        :func:`pool_scores` takes them.

    Raises
    ------
    DataFormatError
        A ``delays_s`` or ``confusion`` cell that is not a list of numbers >= 0 (an item
        that is no number, NaN or a negative delay included, is refused, not dropped) or a
        mapping of decision
        counts (true terrain -> decided terrain -> integer >= 0; the error names the file,
        column and line).
    """
    frame = pd.read_csv(path)

    def fail(column: str, row: int, what: str, cell) -> DataFormatError:
        return DataFormatError(f"not {what}: {str(cell)[:60]!r}", path=str(path),
                               column=column, row=row, line=row + 2)

    if "delays_s" in frame:
        delays = []
        for row, cell in enumerate(frame["delays_s"]):
            text = str(cell).replace("np.float64(", "").replace(")", "")
            # every item a number: one that is not (a NaN, a word) is no delay to drop
            items = [x for x in re.split(r"[,\s]+", text[1:-1]) if x]
            if not (text.startswith("[") and text.endswith("]")) or \
                    re.search(r",\s*,", text) or \
                    not all(_NUMBER.fullmatch(x) for x in items):
                raise fail("delays_s", row, "a list of switching delays", cell)
            values = [float(x.replace("Infinity", "inf")) for x in items]
            if any(v < 0.0 for v in values):    # from a switch to its first decision: >= 0
                raise fail("delays_s", row, "a list of switching delays >= 0 s", cell)
            delays.append(values)
        frame["delays_s"] = delays
    if "confusion" in frame:
        confusion = []
        for row, cell in enumerate(frame["confusion"]):
            try:
                conf = ast.literal_eval(str(cell))
            except (ValueError, SyntaxError):
                conf = None
            if not _is_confusion(conf):
                raise fail("confusion", row, "a mapping of decision counts", cell)
            confusion.append(conf)
        frame["confusion"] = confusion
    return frame


def _is_confusion(conf) -> bool:
    """Whether ``conf`` maps each true terrain to a mapping of decided terrain -> decisions
    (integers >= 0, at least one decision per true terrain), as :func:`pool_scores` sums it."""
    return isinstance(conf, dict) and all(
        isinstance(row, dict) and all(
            isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in row.values())
        and sum(row.values()) > 0 for row in conf.values())


def _weighted_accuracy(accuracy: pd.Series, n: pd.Series) -> float:
    """Mean of ``accuracy`` weighted by ``n`` over the rows with ``n > 0`` (a row without a
    decision has accuracy NaN and no weight; NaN when no row has one)."""
    some = n > 0
    return float(np.average(accuracy[some], weights=n[some])) if some.any() else float("nan")


def seed_accuracies(rows: pd.DataFrame) -> dict[int, float]:
    """Per-decision accuracy of every seed, pooled over its folds.

    Parameters
    ----------
    rows : pandas.DataFrame
        Score rows of one smoothing with a ``seed`` column.

    Returns
    -------
    dict
        Seed -> accuracy weighted by decisions (rows without a decision have no weight;
        NaN for a seed without any).
    """
    return {int(seed): _weighted_accuracy(g["accuracy"], g["n_decisions"])
            for seed, g in rows.groupby("seed")}


def pool_scores(rows: pd.DataFrame) -> dict:
    """Rows of :func:`held_out_streams` (one smoothing, any folds and seeds) pooled.

    Parameters
    ----------
    rows : pandas.DataFrame
        Rows with ``accuracy, n_decisions, accuracy_settled, n_settled, delays_s,
        confusion``.

    Returns
    -------
    dict
        ``accuracy`` (weighted by decisions), ``accuracy_settled`` (weighted by settled
        decisions; rows without any have no weight, and NaN when no row has one),
        ``median_delay_s`` (median of every switching delay, s), ``n_switches``,
        ``recall`` (true class -> share of its decisions naming it) and ``confusion`` (the
        summed true -> decided counts). No rows pool to NaN scores, no switch, and empty
        ``recall`` and ``confusion``.
    """
    # no rows (a selection that holds none): no switch, as a row without one
    delays = np.concatenate([np.empty(0)] + [np.asarray(d, float) for d in rows["delays_s"]])
    confusion: dict[str, dict[str, int]] = {}
    for conf in rows["confusion"]:
        for true, row in conf.items():
            out = confusion.setdefault(true, {})
            for got, n in row.items():
                out[got] = out.get(got, 0) + int(n)
    return {"accuracy": _weighted_accuracy(rows["accuracy"], rows["n_decisions"]),
            "accuracy_settled": _weighted_accuracy(rows["accuracy_settled"],
                                                   rows["n_settled"]),
            "median_delay_s": float(np.median(delays)) if delays.size else float("nan"),
            "n_switches": int(delays.size),
            "recall": {t: row.get(t, 0) / sum(row.values())
                       for t, row in sorted(confusion.items())},
            "confusion": confusion}


def window_cv(runs: Sequence[Run], recipe: ModelRecipe, hop_s: float, seeds: Sequence[int],
              smoothings: Mapping[str, SmoothingConfig], n_splits: int = 5) -> dict:
    """Run-grouped window accuracy of a recipe, seeds pooled, raw and smoothed.

    Features are computed once (the extractors are stateless); the classifier is fitted
    per training fold (StratifiedGroupKFold grouped by run); probabilities are then
    filtered causally along each test run.

    Parameters
    ----------
    runs : sequence of Run
        Labelled runs.
    recipe : ModelRecipe
        Signals, window (history) length, rate, features and classifier.
    hop_s : float
        Hop between windows (decisions), s; the windows are cut a whole number of samples
        apart (:attr:`WindowConfig.hop_samples`), and the filter steps at that hop.
    seeds : sequence of int
        Fold seeds.
    smoothings : Mapping[str, SmoothingConfig]
        Named smoothing settings (``dwell_s=None`` = raw windows).
    n_splits : int
        Folds.

    Returns
    -------
    dict
        ``n_windows``, ``n_runs``, ``pooled_accuracy`` (smoothing -> accuracy over all
        seeds' out-of-fold windows), ``run_mean_accuracy`` (smoothing -> mean over runs of
        the per-run accuracy, so the long runs do not dominate), ``n_undecided``
        (smoothing -> windows without a decision, :data:`NO_DECISION`, all seeds together:
        counted wrong, as stream-eval counts an unclassified window) and ``by_seed``.
    """
    window = WindowConfig(window_s=recipe.window_s, hop_s=hop_s, rate_hz=recipe.rate_hz)
    ws = make_windows(runs, recipe.signals, window)
    # the filter steps at the hop the windows are cut at: a whole number of samples
    # (0.25 s at 10 Hz is cut as 0.2 s)
    cut_hop_s = window.hop_samples / recipe.rate_hz
    labels = ws.labels.astype(str)
    F = recipe_features(recipe, ws.channels, runs_track_m(runs)).fit(ws.X).transform(ws.X)
    by_seed: dict[str, list[float]] = {name: [] for name in smoothings}
    by_run: dict[str, list[float]] = {name: [] for name in smoothings}
    undecided = {name: 0 for name in smoothings}
    for seed in seeds:
        proba, classes = grouped_oof_proba(lambda s: recipe_classifier(recipe, s), F, labels,
                                           ws.run_ids, seed, n_splits, recipe.run_balanced)
        # NO_DECISION (-1) indexes the None after the classes: wrong, never the last class
        names = np.array(list(classes) + [None], dtype=object)
        for name, config in smoothings.items():
            decided = smooth_runs(proba, ws.run_ids, ws.t_start_s, cut_hop_s, config)
            undecided[name] += int((decided == NO_DECISION).sum())
            ok = names[decided] == labels
            by_seed[name].append(float(ok.mean()))
            by_run[name].append(float(pd.Series(ok).groupby(ws.run_ids).mean().mean()))
    return {"n_windows": len(ws), "n_runs": int(len(np.unique(ws.run_ids))),
            "pooled_accuracy": {k: float(np.mean(v)) for k, v in by_seed.items()},
            "run_mean_accuracy": {k: float(np.mean(v)) for k, v in by_run.items()},
            "n_undecided": undecided, "by_seed": by_seed}
