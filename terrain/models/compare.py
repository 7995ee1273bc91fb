"""Model comparison: every model under one run-grouped protocol, as a grid of cells.

A *cell* is one (model, signal set, window length, dataset, seed): a
``StratifiedGroupKFold(n_splits)`` cross-validation grouped by run with that seed
(:func:`terrain.models.cv.cross_validate`). Cells are independent tasks run through
:class:`joblib.Parallel`, so the active joblib backend decides where they run: local
processes (``loky``), a Dask cluster (``joblib.parallel_config(backend="dask")`` with a
``distributed.Client``) or Ray (``ray.util.joblib``), with no other change.

``protocol="paper"`` instead runs the papers' own partition protocol (BorealTC, Vulpi: 5 s
partitions, ``StratifiedKFold(5, shuffle=True, random_state=21 + seed)`` over partitions,
1.7 s windows at 0.1 s hop, :func:`terrain.models.cv.iter_splits`). Partitions of one run fall
on both sides of a split, so it leaks run conditions: every row, table line and MLflow child
run carries ``protocol`` and the tables label it ``paper (LEAKY)``. Never the default.

The *decision history* is a reported dimension, not a cell: from the out-of-fold class
probabilities of a cell, the decision at a window averages the probabilities of the last
``k`` windows of its run (causal, ``k`` in ``history``), see :func:`history_predictions`.
"""

from __future__ import annotations

import importlib.util
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from types import MappingProxyType
from typing import Any, Iterator, NamedTuple, Sequence

import numpy as np
import pandas as pd

from terrain.errors import (ConfigError, NonFiniteInputError, config_integer, config_positive,
                            duplicated, refuse_missing, refuse_mixed_types)
from terrain.models.cv import block_notes, cross_validate, grouped_units
from terrain.models.ensemble import capped_at_one, normalised_weights
from terrain.models.metrics import run_majority_accuracy, window_metrics
from terrain.models.registry import MODELS, ModelConfig, cnn_kinds, cnn_seeds_for, make_model

#: Protocols of the comparison: the run-grouped headline and the papers' leaky partition one.
COMPARE_PROTOCOLS = ("grouped", "paper")
#: How each protocol is labelled in tables and figures.
PROTOCOL_LABELS = MappingProxyType({"grouped": "grouped", "paper": "paper (LEAKY)"})

#: Metrics of the comparison table (window level, then run-level majority vote).
TABLE_METRICS = ("accuracy", "balanced_accuracy", "macro_f1", "run_vote_accuracy")


@dataclass(frozen=True)
class Cell:
    """One cross-validation of the grid.

    Parameters
    ----------
    model : str
        Model name (:data:`terrain.models.registry.MODELS`).
    signals : str
        Signal set (``imu``, ``wheels``, ``all``, ``all+ekf``).
    window_s : float
        Window length, s (non-overlapping windows).
    dataset : str
        Shipped dataset.
    seed : int
        Split and model seed.
    protocol : {"grouped", "paper"}
        ``grouped``: run-grouped ``StratifiedGroupKFold`` (headline); ``paper``: the papers'
        leaky 5 s partition protocol (1.7 s windows, see the module docstring).
    train_hop_s : float or None
        Hop of the training windows, s: each fold trains on windows cut this often from its
        training runs (:class:`terrain.models.cv.TrainingWindows`); the test windows stay
        the non-overlapping ones. ``None``: train on the non-overlapping windows.
    """

    model: str
    signals: str
    window_s: float
    dataset: str
    seed: int
    protocol: str = "grouped"
    train_hop_s: float | None = None


@dataclass(frozen=True)
class CompareConfig:
    """The comparison grid.

    Parameters
    ----------
    models, signals, datasets : tuple of str
        Grid axes.
    windows_s : tuple of float
        Window lengths, s.
    seeds : tuple of int
        Seeds (one cell each).
    history : tuple of int
        Decision-history lengths ``k`` (windows) reported for every cell.
    n_splits : int
        Folds of the grouped CV.
    max_epochs : int
        Fixed epoch budget of the CNNs.
    n_threads : int or None
        torch threads per CNN fit.
    single_run_blocks : int
        Blocks a single-run class is cut into (>= 2, see :mod:`terrain.models.cv`).
    protocol : {"grouped", "paper"}
        Split protocol of every cell (``paper`` is leaky and needs ``windows_s == (1.7,)``,
        the papers' window).
    early_stopping : bool
        CNNs stop on whole held-out training runs (``max_epochs`` is the upper bound).
    train_hop_s : float or None
        Hop of the training windows of every cell, s (see :class:`Cell`); grouped protocol
        only.
    cnn_seeds : int
        Independently seeded networks averaged per CNN (``ModelConfig.cnn_seeds``), for the
        cells whose model holds a CNN (the others are unchanged).

    Raises
    ------
    ConfigError
        An unknown model, dataset, signal set or protocol; a window length, seed or
        ``train_hop_s`` or ``single_run_blocks`` that
        :class:`~terrain.models.experiment.ExperimentConfig` refuses;
        ``cnn_seeds`` without a CNN model; a value repeated on an axis (models, signals,
        windows_s, datasets, history; a repeated seed is ExperimentConfig's refusal); an
        empty axis (no cell); no seed, a history length that is not an integer >= 1,
        ``max_epochs`` not an integer >= 1 or ``n_splits`` not an integer >= 2; ``n_threads``
        outside 1-``MAX_TORCH_THREADS`` (:class:`~terrain.models.registry.ModelConfig`'s
        rule).
    """

    models: tuple[str, ...] = MODELS
    signals: tuple[str, ...] = ("imu", "wheels", "all", "all+ekf")
    windows_s: tuple[float, ...] = (1.0, 2.0, 4.0)
    datasets: tuple[str, ...] = ("borealtc", "vulpi", "combined")
    seeds: tuple[int, ...] = (0, 1, 2)
    history: tuple[int, ...] = (1, 5, 10)
    n_splits: int = 5
    max_epochs: int = 30
    n_threads: int | None = None
    single_run_blocks: int = 5
    protocol: str = "grouped"
    early_stopping: bool = False
    train_hop_s: float | None = None
    cnn_seeds: int = 1

    def __post_init__(self) -> None:
        if self.cnn_seeds != 1:
            ModelConfig(kind="cnn", cnn_seeds=self.cnn_seeds)    # ModelConfig's own rule
            if not any(cnn_kinds(m) for m in self.models):
                raise ConfigError(f"cnn_seeds={self.cnn_seeds} averages CNNs and none of the "
                                  f"models {list(self.models)} has one")
        if self.protocol not in COMPARE_PROTOCOLS:
            raise ConfigError(f"unknown protocol {self.protocol!r}; valid: "
                              f"{list(COMPARE_PROTOCOLS)}")
        if self.train_hop_s is not None:   # (text such as '0.5': Python's bare TypeError)
            config_positive("CompareConfig", train_hop_s=self.train_hop_s)
        if self.train_hop_s is not None and self.protocol != "grouped":
            raise ConfigError("train_hop_s must be > 0 s and needs the grouped protocol (the "
                              f"paper protocol fixes its windows); got {self.train_hop_s}")
        if self.protocol == "paper":
            from terrain.models.experiment import PAPER_WINDOW

            if tuple(self.windows_s) != (PAPER_WINDOW["window_s"],):
                raise ConfigError(f"the paper protocol fixes {PAPER_WINDOW['window_s']:g} s "
                                  f"windows at {PAPER_WINDOW['hop_s']:g} s hop; pass "
                                  f"--windows-s {PAPER_WINDOW['window_s']:g}")
        bad = [m for m in self.models if m not in MODELS]
        if bad:
            raise ConfigError(f"unknown model(s) {bad}; valid: {list(MODELS)}")
        # (repeated seeds: ExperimentConfig's own check, run below for every cell)
        for axis in ("models", "signals", "windows_s", "datasets", "history"):
            if not len(getattr(self, axis)):  # no cell at all: summary_table had no column
                raise ConfigError(f"{axis} is empty: the grid would have no cell")
            repeated = duplicated(getattr(self, axis))
            if repeated:  # a repeated value would fit its cells twice and count them as two
                raise ConfigError(f"{axis} must be distinct: {repeated} given more than once")
        if not self.seeds:
            raise ConfigError("need at least one seed")
        # (2.5 failed in every cell, after its CV, in pandas; '5' in a bare min() here)
        for k in self.history:
            config_integer("CompareConfig.history", k, 1)
        # (n_splits 2.5 passed a '< 2' check, then failed in every cell after its data)
        config_integer("CompareConfig.max_epochs", self.max_epochs, 1)
        config_integer("CompareConfig.n_splits", self.n_splits, 2)
        for model in self.models:  # the model's own rules (threads, ...)
            ModelConfig(kind=model, n_threads=self.n_threads,
                        cnn_seeds=cnn_seeds_for(model, self.cnn_seeds))
        from terrain.models.experiment import ExperimentConfig

        for dataset in self.datasets:  # every axis value's own checks, before any data
            for signals in self.signals:
                for window_s in self.windows_s:
                    ExperimentConfig(dataset=dataset, signals=(signals,), window_s=window_s,
                                     protocol=self.protocol, seeds=self.seeds,
                                     train_hop_s=self.train_hop_s,
                                     single_run_blocks=self.single_run_blocks)
        # the caller's lists were kept: changing one later changed the validated grid
        for axis in ("models", "signals", "windows_s", "datasets", "seeds", "history"):
            object.__setattr__(self, axis, tuple(getattr(self, axis)))

    def cells(self) -> list[Cell]:
        """Every cell of the grid (model varies fastest).

        Returns
        -------
        list of Cell
            ``len(datasets) * len(windows_s) * len(signals) * len(seeds) * len(models)``
            cells.
        """
        return [Cell(m, s, w, d, seed, self.protocol, self.train_hop_s) for d in self.datasets
                for w in self.windows_s for s in self.signals for seed in self.seeds
                for m in self.models]


def _start(value) -> str:
    """A window's start for a message: ``:g`` of a number, anything else (a start read as
    text) as it is (``:g`` raised a bare ValueError in the middle of a refusal)."""
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        return f"{value:g}"
    return str(value)


def _probabilities(owner: str, frame: pd.DataFrame, classes: Sequence[str],
                   run: str) -> np.ndarray:
    """``(n_rows, n_classes)`` the ``proba_<CLASS>`` columns of ``frame`` as floats.

    ConfigError for classes repeated or without a column (pandas' bare KeyError),
    NonFiniteInputError for a NaN or infinite probability (argmax decided its window as the
    first class), naming the window by its ``run`` column and ``t_start_s``.
    """
    repeated = duplicated(classes)
    if repeated:
        raise ConfigError(f"{owner}: classes must be distinct, {repeated} given more than once")
    cols = [f"proba_{c}" for c in classes]
    absent = [c for c in cols if c not in frame.columns]
    if absent:
        raise ConfigError(f"{owner}: no column {absent} for the classes {list(classes)}; the "
                          f"probability columns are "
                          f"{[c for c in frame.columns if str(c).startswith('proba_')]}")
    proba = frame[cols].to_numpy(dtype=float)
    bad = ~np.isfinite(proba).all(axis=1)
    if bad.any():
        row = frame[bad].iloc[0]
        raise NonFiniteInputError(f"{owner}: {int(bad.sum())} window(s) with a NaN or "
                                  f"infinite probability among {cols} (e.g. {row[run]} at "
                                  f"{_start(row['t_start_s'])} s): argmax would decide them as "
                                  f"{classes[0]!r}")
    return proba


def history_predictions(predictions: pd.DataFrame, classes: Sequence[str], k: int
                        ) -> np.ndarray:
    """Decisions from the class probabilities averaged over the last ``k`` windows of a run.

    Parameters
    ----------
    predictions : pandas.DataFrame
        Out-of-fold rows of one seed with ``group``, ``t_start_s`` and ``proba_<CLASS>``
        columns (:attr:`terrain.models.cv.CVReport.predictions`).
    classes : sequence of str
        Class order of the probability columns.
    k : int
        History length, windows (1: the window alone). Only earlier windows of the same
        run (split unit) enter the mean: the decision is causal.

    Returns
    -------
    numpy.ndarray
        ``(n_rows,)`` predicted labels, aligned with ``predictions``' rows: the class of the
        largest mean probability (over fewer than ``k`` windows at the start of a run; a tie
        goes to the first class in ``classes`` order).

    Raises
    ------
    ConfigError
        Two rows of one window (same ``group`` and ``t_start_s``): rows of several seeds or
        cells, whose histories would be averaged into each other; ``k`` not an integer >= 1;
        ``classes`` repeated, or without its ``proba_<CLASS>`` column.
    NonFiniteInputError
        A probability is NaN or infinite (its windows, and the ``k - 1`` after them, would
        all be decided as the first class), a start time not a finite number, or a group
        missing (NaN or None).
    MixedTypesError
        Groups of mixed types: text beside numbers (run ``1`` beside run ``"1"``) or
        booleans beside numbers (:func:`terrain.errors.refuse_mixed_types`).
    """
    # (k = 0 averaged no window: 0/0, every decision the first class, without a word)
    config_integer("history_predictions: k", k, 1)
    # (a NaN start sorted last, as the run's latest window; a missing group made each of its
    # windows a run of its own)
    refuse_missing("history_predictions", "group", predictions["group"], "run(s)",
                   "every window needs its run")
    # (run 1 beside run "1", both shown as 1, were two runs with a history each; True beside
    # 1 one run; text beside numbers a bare TypeError of the sort)
    refuse_mixed_types("history_predictions", "group", predictions["group"])
    starts = pd.to_numeric(predictions["t_start_s"], errors="coerce").to_numpy(dtype=float)
    if not np.isfinite(starts).all():
        where = int(np.flatnonzero(~np.isfinite(starts))[0])
        raise NonFiniteInputError(f"history_predictions: t_start_s holds "
                                  f"{int((~np.isfinite(starts)).sum())} value(s) that are not "
                                  f"finite numbers, the first at row {where}: a window's "
                                  "place in its run decides its history")
    twice = predictions.duplicated(["group", "t_start_s"])
    if twice.any():
        first = predictions.loc[twice, ["group", "t_start_s"]].iloc[0]
        raise ConfigError(f"{int(twice.sum())} window(s) given more than once (e.g. "
                          f"{first['group']} at {_start(first['t_start_s'])} s): the decision "
                          "history takes the rows of one seed of one cell")
    # by row position: a frame's own index may repeat (frames joined by pd.concat)
    order = predictions.reset_index(drop=True).sort_values(["group", "t_start_s"],
                                                           kind="stable")
    proba = _probabilities("history_predictions", order, classes, "group")
    group = order["group"].to_numpy()
    n = len(order)
    first = np.ones(n, dtype=bool)
    first[1:] = group[1:] != group[:-1]
    start = np.maximum.accumulate(np.where(first, np.arange(n), 0))   # row of the run's start
    # the sum of exactly the last k windows, oldest first (a rolling mean's running sum kept
    # the rounding of windows that left the history: a tie of the last k went either way)
    total = np.zeros_like(proba)
    count = np.zeros(n)
    for lag in range(min(k, n) - 1, -1, -1):
        at = np.arange(n) - lag
        inside = at >= start
        total[inside] += proba[at[inside]]
        count += inside
    labels = np.empty(n, dtype=object)
    labels[order.index.to_numpy()] = np.asarray(classes, dtype=object)[
        (total / count[:, None]).argmax(axis=1)]
    return labels


def score_rows(predictions: pd.DataFrame, classes: Sequence[str], history: Sequence[int],
               fields: dict) -> list[dict]:
    """Table metrics of out-of-fold predictions at every history length.

    Parameters
    ----------
    predictions : pandas.DataFrame
        Rows of one cell and seed: ``true``, ``group``, ``t_start_s``, ``proba_<CLASS>``.
    classes : sequence of str
        Class order.
    history : sequence of int
        History lengths ``k`` (windows).
    fields : dict
        Copied into every row (cell fields, timings).

    Returns
    -------
    list of dict
        One row per ``k``: ``history``, :data:`TABLE_METRICS`, ``n_windows`` and ``fields``.

    Raises
    ------
    ConfigError
        A window given more than once (rows of several seeds, :func:`history_predictions`).
    """
    rows = []
    for k in history:
        p = history_predictions(predictions, classes, k)
        m = window_metrics(predictions["true"], p, classes)
        rows.append({**fields, "history": k, **{key: m[key] for key in TABLE_METRICS[:3]},
                     "run_vote_accuracy": run_majority_accuracy(predictions["true"], p,
                                                                predictions["group"]),
                     "n_windows": int(len(predictions))})
    return rows


def soft_vote(members: Sequence[pd.DataFrame], classes: Sequence[str],
              weights: Sequence[float] | None = None) -> pd.DataFrame:
    """Soft vote of out-of-fold probabilities of models cross-validated on the same folds.

    With fixed weights (no tuning) this is exactly the out-of-fold prediction of
    :class:`terrain.models.ensemble.SoftVotingEnsemble` with those weights, because each
    member is trained deterministically on the same training fold.

    Parameters
    ----------
    members : sequence of pandas.DataFrame
        Predictions of each model (same seed, folds and windows; ``proba_<CLASS>``).
    classes : sequence of str
        Class order.
    weights : sequence of float or None
        Member weights (normalised); ``None``: equal.

    Returns
    -------
    pandas.DataFrame
        The first member's frame with averaged probabilities and ``predicted``.

    Raises
    ------
    ConfigError
        No member, the members do not cover the same windows in the same folds, a
        member gives one window (``seed``, ``fold``, ``run``, ``t_start_s``) more than once
        (rows of several cells: its rows could not be paired with the other members'), or
        ``weights`` are not one per member, negative or all 0
        (:func:`~terrain.models.ensemble.normalised_weights`); ``classes`` repeated, or a
        member without the ``proba_<CLASS>`` column of one.
    NonFiniteInputError
        A NaN or infinite probability (its window was decided as the first class).
    """
    if not len(members):     # (a bare IndexError before)
        raise ConfigError("soft_vote needs at least one member's predictions, got none")
    key = ["seed", "fold", "run", "t_start_s"]
    base = members[0].sort_values(key).reset_index(drop=True)
    cols = [f"proba_{c}" for c in classes]
    for frame in members:
        _probabilities("soft_vote", frame, classes, "run")
        # (rows of one window were paired with the other members' by their order in the frame)
        twice = frame.duplicated(key)
        if twice.any():
            first = frame.loc[twice.to_numpy(), key].iloc[0]
            raise ConfigError(f"soft_vote: {int(twice.sum())} window(s) given more than once "
                              f"in a member (e.g. {first['run']} at "
                              f"{_start(first['t_start_s'])} s, seed {first['seed']}, fold "
                              f"{first['fold']}): give the rows of one cell per member")
    w = (np.full(len(members), 1.0 / len(members)) if weights is None
         else normalised_weights(weights, len(members)))
    total = np.zeros((len(base), len(cols)))
    for wi, frame in zip(w, members):
        frame = frame.sort_values(key).reset_index(drop=True)
        if not frame[key].equals(base[key]):
            raise ConfigError("soft_vote needs predictions of the same folds and windows")
        total += wi * frame[cols].to_numpy(dtype=float)
    out = base.copy()
    out[cols] = capped_at_one(total)     # as SoftVotingEnsemble.predict_proba
    out["predicted"] = np.asarray(classes, dtype=object)[total.argmax(axis=1)]
    return out


class CellWindows(NamedTuple):
    """The windows of one comparison cell (:func:`cell_windows`).

    Attributes
    ----------
    ws : features.windows.WindowSet
        The evaluation windows.
    labels : numpy.ndarray
        ``(n_windows,)`` class names.
    groups : numpy.ndarray
        ``(n_windows,)`` split units (runs, or blocks of a single-run class).
    training : TrainingWindows or None
        The cell's training cut when it has a ``train_hop_s``
        (:class:`~terrain.models.cv.TrainingWindows`), else None.
    split_classes : tuple of str
        Classes with a single run, cut into time blocks (none under the paper protocol).
    n_dropped : int
        Windows dropped for straddling a block boundary.
    notes : tuple of str
        What the cut changed, each prefixed with the dataset, in the words of ``terrain
        cv``'s notes (:func:`~terrain.models.cv.block_notes`).
    """

    ws: Any
    labels: np.ndarray
    groups: np.ndarray
    training: Any
    split_classes: tuple = ()
    n_dropped: int = 0
    notes: tuple = ()


def cell_windows(cell: Cell, n_blocks: int) -> CellWindows:
    """The windows a cell is cross-validated on, as ``terrain cv`` cuts them.

    Single-run classes are split into ``n_blocks`` contiguous time blocks used as groups and
    windows straddling a block boundary dropped (both reported in the result); under the
    paper protocol the 1.7 s windows are grouped by 5 s partition.

    Parameters
    ----------
    cell : Cell
        The grid point (dataset, signals, window, protocol, training hop).
    n_blocks : int
        Blocks a single-run class is cut into.

    Returns
    -------
    CellWindows
        ``(ws, labels, groups, training, split_classes, n_dropped, notes)``.

    Raises
    ------
    ConfigError
        No window left (every run shorter than the window,
        :func:`~terrain.models.experiment.check_windows_left`), or windows of one terrain
        class only.
    """
    from terrain.io.shipped import load_dataset
    from terrain.models.experiment import (ExperimentConfig, check_two_classes,
                                           check_windows_left, load_training_windows,
                                           load_windows)

    config = ExperimentConfig(dataset=cell.dataset, signals=(cell.signals,),
                              window_s=cell.window_s, protocol=cell.protocol,
                              train_hop_s=cell.train_hop_s)
    runs = load_dataset(cell.dataset)
    ws = load_windows(config, runs)
    check_windows_left(ws, config)     # (else the CV's '5 folds over 0 split units')
    check_two_classes(ws.labels.astype(str), cell.dataset, ws.run_ids)
    if cell.protocol == "paper":
        return CellWindows(ws, ws.labels.astype(str), ws.groups, None)
    ws, labels, groups, split, n_dropped = grouped_units(ws, n_blocks)
    notes = tuple(f"{cell.dataset}: {note}"
                  for note in block_notes(labels, groups, split, n_blocks, n_dropped))
    return CellWindows(ws, labels, groups, load_training_windows(config, runs, ws, groups),
                       tuple(split), n_dropped, notes)


#: Settings a cell's figures depend on beyond its key: the folds (every model) and a CNN's
#: training (models that hold one); recorded in every row so that merged folders can be
#: checked for them (``benchmarks/merge_compare.py``).
PROTOCOL_SETTINGS = ("n_splits", "single_run_blocks")
CNN_SETTINGS = ("max_epochs", "early_stopping", "cnn_seeds")


def protocol_settings(model: str, config: CompareConfig) -> dict:
    """The settings of :data:`PROTOCOL_SETTINGS` and :data:`CNN_SETTINGS` one cell ran under.

    Parameters
    ----------
    model : str
        The cell's model (:data:`~terrain.models.registry.MODELS`).
    config : CompareConfig
        The grid's settings.

    Returns
    -------
    dict
        Setting -> value; the CNN settings are None for a model without a CNN (they do not
        touch it, so folders that differ only there are not in conflict).
    """
    cnn = bool(cnn_kinds(model))
    return {"n_splits": config.n_splits, "single_run_blocks": config.single_run_blocks,
            "max_epochs": config.max_epochs if cnn else None,
            "early_stopping": config.early_stopping if cnn else None,
            "cnn_seeds": cnn_seeds_for(model, config.cnn_seeds) if cnn else None}


def run_cell(cell: Cell, config: CompareConfig) -> dict:
    """Cross-validate one cell and score it at every history length.

    Parameters
    ----------
    cell : Cell
        The grid point.
    config : CompareConfig
        Folds, epochs, threads and history lengths.

    Returns
    -------
    dict
        ``cell`` (its fields), ``rows`` (one dict per history length: the table metrics,
        ``fit_s_per_fold``, ``infer_ms_per_window``, ``n_windows``, ``n_windows_dropped``
        and the settings of :func:`protocol_settings`),
        ``folds`` (frame), ``predictions`` (frame with probabilities) and ``notes`` (what
        the cut into time blocks changed, :attr:`CellWindows.notes`).
    """
    cut = cell_windows(cell, config.single_run_blocks)
    ws, labels, groups, training = cut[:4]
    mc = ModelConfig(kind=cell.model, max_epochs=config.max_epochs,
                     n_threads=config.n_threads, early_stopping=config.early_stopping,
                     cnn_seeds=cnn_seeds_for(cell.model, config.cnn_seeds))
    factory = (lambda seed: make_model(mc, ws.channels, ws.rate_hz, cell.dataset, seed))
    t0 = time.perf_counter()
    report = cross_validate(factory, ws.X, labels, groups, ws.run_ids, ws.t_start_s,
                            ws.t_end_s, cell.protocol, (cell.seed,), config.n_splits,
                            time_inference=20, training=training)
    wall_s = time.perf_counter() - t0
    pred = report.predictions
    rows = score_rows(pred, report.classes, config.history,
                      {**asdict(cell), "fit_s_per_fold": float(report.folds["fit_s"].mean()),
                       "infer_ms_per_window": float(report.folds["infer_ms_per_window"].mean()),
                       "cell_wall_s": wall_s, "n_windows_dropped": cut.n_dropped,
                       **protocol_settings(cell.model, config),
                       **({"epochs_per_fold": float(report.folds["n_epochs"].mean())}
                          if "n_epochs" in report.folds else {})})
    return {"cell": asdict(cell), "rows": rows, "folds": report.folds.assign(**asdict(cell)),
            "predictions": pred.assign(**asdict(cell)), "notes": list(cut.notes)}


def iter_grid(config: CompareConfig, n_jobs: int | None = None) -> Iterator[dict]:
    """Run every cell through :class:`joblib.Parallel` and yield each result as it is ready.

    The active joblib backend decides where the cells run; results come back in
    :meth:`CompareConfig.cells` order (``return_as="generator"``), so a caller can log,
    save and show progress cell by cell instead of after the whole grid.

    Parameters
    ----------
    config : CompareConfig
        The grid.
    n_jobs : int or None
        joblib workers (``None``: sequential unless a backend context says otherwise;
        ``-1``: every worker of the backend).

    Yields
    ------
    dict
        :func:`run_cell` results, in :meth:`CompareConfig.cells` order. An error of a cell
        propagates when its result is reached.
    """
    from joblib import Parallel, delayed

    yield from Parallel(n_jobs=n_jobs, return_as="generator")(
        delayed(run_cell)(c, config) for c in config.cells())


def run_grid(config: CompareConfig, n_jobs: int | None = None) -> list[dict]:
    """Every cell's result (:func:`iter_grid`, collected).

    Parameters
    ----------
    config : CompareConfig
        The grid.
    n_jobs : int or None
        joblib workers (``None``: sequential unless a backend context says otherwise;
        ``-1``: every worker of the backend).

    Returns
    -------
    list of dict
        :func:`run_cell` results, in :meth:`CompareConfig.cells` order.
    """
    return list(iter_grid(config, n_jobs))


def with_default_keys(frame: pd.DataFrame) -> pd.DataFrame:
    """Fill the keys that older rows lack: ``protocol`` (``grouped``) and ``train_hop_s``
    (the window length, i.e. non-overlapping training windows).

    Parameters
    ----------
    frame : pandas.DataFrame
        Cells, rows or predictions with ``window_s``.

    Returns
    -------
    pandas.DataFrame
        A copy with both columns filled.
    """
    protocol = frame["protocol"].fillna("grouped") if "protocol" in frame else "grouped"
    hop = (frame["train_hop_s"].astype(float).fillna(frame["window_s"])
           if "train_hop_s" in frame else frame["window_s"])
    return frame.assign(protocol=protocol, train_hop_s=hop)


def summary_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Mean and spread (std over seeds) of every metric per model x signals x window x
    dataset x history.

    Parameters
    ----------
    rows : pandas.DataFrame
        The ``rows`` of every cell (one per cell and history length).

    Returns
    -------
    pandas.DataFrame
        One row per group: ``<metric>_mean``, ``<metric>_std`` (the population std over
        the seeds, ddof=0, as :meth:`~terrain.models.cv.CVReport.summary`; 0 for one seed)
        for the table metrics, ``fit_s_per_fold``, ``infer_ms_per_window`` (means) and
        ``n_seeds`` (rows of the group). A value missing (NaN) in any of the group's rows
        makes its mean and std NaN: they are never those of fewer seeds than ``n_seeds``
        says.
    """
    rows = with_default_keys(rows)
    keys = ["protocol", "dataset", "signals", "window_s", "train_hop_s", "history", "model"]
    g = rows.groupby(keys, sort=True)
    out = pd.concat([g[list(TABLE_METRICS)].mean(skipna=False).add_suffix("_mean"),
                     g[list(TABLE_METRICS)].std(ddof=0, skipna=False).add_suffix("_std"),
                     g[["fit_s_per_fold", "infer_ms_per_window"]].mean(skipna=False),
                     g.size().rename("n_seeds")], axis=1)
    return out.reset_index()


def markdown_table(table: pd.DataFrame) -> str:
    """The summary as a Markdown table (``mean ± std`` cells, times rounded).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`summary_table` output.

    Returns
    -------
    str
        GitHub-flavoured Markdown.
    """
    head = ["dataset", "signals", "window s", "train hop s", "history k", "model", "accuracy",
            "balanced acc.", "macro-F1", "run vote acc.", "train s/fold", "infer ms/window",
            "seeds", "protocol"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for _, r in table.iterrows():
        cells = [r["dataset"], r["signals"], f"{r['window_s']:g}",
                 f"{r.get('train_hop_s', r['window_s']):g}", str(int(r["history"])), r["model"]]
        cells += [f"{r[m + '_mean']:.3f} ± {r[m + '_std']:.3f}" for m in TABLE_METRICS]
        cells += [f"{r['fit_s_per_fold']:.1f}", f"{r['infer_ms_per_window']:.2f}",
                  str(int(r["n_seeds"])),
                  PROTOCOL_LABELS.get(r.get("protocol", "grouped"), r.get("protocol"))]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def grid_markdown(table: pd.DataFrame, history: Sequence[int] = (1, 10)) -> str:
    """The grid as compact Markdown: per dataset, signal sets x window lengths x models.

    One table per dataset; a row per signal set and model, a column per window length and
    history; each cell ``accuracy / macro-F1`` (means over seeds), the best accuracy of each
    column in bold, ``-`` where the cell was not run (a signal set and model never run is
    left out).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`summary_table` output of one protocol.
    history : sequence of int
        Decision histories k to show (those the table holds).

    Returns
    -------
    str
        GitHub-flavoured Markdown, one ``#### <dataset>`` section per dataset.

    Raises
    ------
    ConfigError
        The table mixes protocols or training-window hops.
    """
    _one_setting(table)
    history = [k for k in history if k in set(table["history"])]
    windows = sorted(set(table["window_s"]))
    columns = [(k, w) for k in history for w in windows]
    out = []
    for ds in dict.fromkeys(table["dataset"]):
        sub = table[table["dataset"] == ds]
        best = sub.groupby(["history", "window_s"])["accuracy_mean"].max()
        scores = sub.set_index(["signals", "model", "history", "window_s"])
        head = ["signals", "model"] + [f"{w:g} s, k = {k}" for k, w in columns]
        lines = [f"#### {ds}", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for sig in dict.fromkeys(sub["signals"]):
            for model in dict.fromkeys(sub["model"]):
                cells = ["-"] * len(columns)
                for i, (k, w) in enumerate(columns):
                    if (sig, model, k, w) in scores.index:
                        acc, f1 = scores.loc[(sig, model, k, w),
                                             ["accuracy_mean", "macro_f1_mean"]]
                        text = f"{acc:.3f} / {f1:.3f}"
                        cells[i] = f"**{text}**" if acc == best[(k, w)] else text
                if any(c != "-" for c in cells):
                    lines.append("| " + " | ".join([sig, model] + cells) + " |")
        out.append("\n".join(lines) + "\n")
    return "\n".join(out)


def plot_comparison(table: pd.DataFrame):
    """Accuracy (mean ± std over seeds) per model, one panel per dataset, one bar per
    history length (a model, signal set and window not run at a history has no bar there).

    The accuracy axis of a panel runs from 0.6 to 1, from lower where a bar or its spread
    reaches below 0.6 (a tenth at least 0.05 under the lowest, 0 at the lowest).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`summary_table` output (all signal sets and windows are drawn side by side).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure     # not pyplot's: no figure left open per call

    table = table if "protocol" in table else table.assign(protocol="grouped")
    datasets = list(dict.fromkeys(zip(table["protocol"], table["dataset"])))
    fig = Figure(figsize=(5 * len(datasets), 3.8))
    axes = fig.subplots(1, len(datasets), squeeze=False)
    for ax, (protocol, ds) in zip(axes[0], datasets):
        sub = table[(table["dataset"] == ds) & (table["protocol"] == protocol)]
        hops = sub["train_hop_s"] if "train_hop_s" in sub else sub["window_s"]
        combos = list(zip(sub["model"], sub["signals"], sub["window_s"], hops))
        slot = {c: i for i, c in enumerate(dict.fromkeys(combos))}
        labels = [f"{m}\n{s} {w:g}s" + (f" (train hop {h:g}s)" if h != w else "")
                  for m, s, w, h in slot]
        histories = sorted(set(sub["history"]))
        width = 0.8 / len(histories)
        for i, k in enumerate(histories):
            at = (sub["history"] == k).to_numpy()
            # each bar at its own (model, signals, window) slot: a combination not run at
            # this k leaves its slot empty instead of shifting the bars after it
            x = np.array([slot[c] for c, a in zip(combos, at) if a]) + i * width
            h = sub[at]
            ax.bar(x, h["accuracy_mean"], width, yerr=h["accuracy_std"], label=f"k={k}")
        ax.set_xticks(np.arange(len(labels)) + 0.4 - width / 2, labels, rotation=60,
                      fontsize=7, ha="right")
        # from 0.6, lower where a bar or its spread reaches below (a bar under the floor
        # was not drawn at all): a tenth at least 0.05 under the lowest, not under 0
        lowest = (sub["accuracy_mean"] - sub["accuracy_std"].fillna(0.0)).min()
        floor = np.floor(10.0 * (lowest - 0.05)) / 10.0 if np.isfinite(lowest) else 0.6
        ax.set_ylim(max(0.0, min(0.6, floor)), 1.0)
        ax.grid(axis="y", alpha=0.3)
        ax.set_ylabel("accuracy (run-grouped CV)" if protocol == "grouped"
                      else "accuracy (papers' LEAKY partition CV)")
        ax.set_title(f"{ds} ({PROTOCOL_LABELS.get(protocol, protocol)})")
    axes[0, -1].legend(title="history", fontsize=7, loc="upper left",
                       bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    return fig


def spans_grid(table: pd.DataFrame) -> bool:
    """Whether a table of one setting holds more than one signal set or window length of a
    dataset (a table mixing protocols or training-window hops does not: see
    :func:`n_settings`).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`summary_table` output.

    Returns
    -------
    bool
        True when :func:`plot_grid` has something to show.
    """
    if n_settings(table) > 1:
        return False
    return bool((table.groupby("dataset")[["signals", "window_s"]].nunique() > 1)
                .any(axis=None))


def n_settings(table: pd.DataFrame) -> int:
    """Distinct (protocol, training-window hop) settings among a table's rows.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`summary_table` output (``protocol`` / ``train_hop_s`` optional).

    Returns
    -------
    int
        1 for a table of one setting; the grid views need exactly one. A training hop
        equal to the window length (or unset) counts as the non-overlapping cut.
    """
    keyed = with_default_keys(table)          # unset: grouped, a hop of the window length
    hop = keyed["train_hop_s"].astype(float)
    cut = np.where(np.isclose(hop, keyed["window_s"].astype(float)), "non-overlapping",
                   hop.astype(str))
    return len(set(zip(keyed["protocol"].astype(str), cut)))


def _one_setting(table: pd.DataFrame) -> None:
    """Refuse a table that mixes protocols or training-window hops (cells would be averaged)."""
    if n_settings(table) > 1:
        raise ConfigError("the grid view needs rows of one protocol and one training-window "
                          "hop; select them first (columns protocol, train_hop_s)")


def plot_grid(table: pd.DataFrame, history: int = 1):
    """Accuracy over signal set x window length: one heatmap per dataset and model.

    Each cell shows the mean accuracy over seeds at decision history ``history`` (colour and
    first line) and macro-F1 (second line); a blank cell was not run. The colour scale runs
    from 0.5 to 1, from the tenth at or under the lowest cell where that is below 0.5.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`summary_table` output of one protocol.
    history : int
        Decision history k of the shown scores (windows).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ConfigError
        The table has no row at that history, or mixes protocols or training-window hops.
    """
    from matplotlib.figure import Figure     # not pyplot's: no figure left open per call

    _one_setting(table)
    sub = table[table["history"] == history]
    if sub.empty:
        raise ConfigError(f"no row at history k = {history}; the table has "
                          f"{sorted(set(table['history']))}")
    datasets = list(dict.fromkeys(sub["dataset"]))
    models = list(dict.fromkeys(sub["model"]))
    signals = list(dict.fromkeys(sub["signals"]))
    # colours from 0.5, from the tenth at or under the lowest cell where it is below (a
    # cell under the scale took the colour of 0.5)
    lowest = sub["accuracy_mean"].min()
    vmin = max(0.0, min(0.5, np.floor(10.0 * lowest) / 10.0)) if np.isfinite(lowest) else 0.5
    windows = sorted(set(sub["window_s"]))
    fig = Figure(figsize=(1.1 * len(windows) * len(datasets) + 1.5,
                          0.55 * len(signals) * len(models) + 1.0))
    axes = fig.subplots(len(models), len(datasets), squeeze=False)
    for i, model in enumerate(models):
        for j, ds in enumerate(datasets):
            ax = axes[i, j]
            cells = sub[(sub["model"] == model) & (sub["dataset"] == ds)]
            acc = (cells.pivot_table(index="signals", columns="window_s",
                                     values="accuracy_mean")
                   .reindex(index=signals, columns=windows))
            f1 = (cells.pivot_table(index="signals", columns="window_s", values="macro_f1_mean")
                  .reindex(index=signals, columns=windows))
            image = ax.imshow(acc.to_numpy(dtype=float), vmin=vmin, vmax=1.0, cmap="viridis",
                              aspect="auto")
            for r in range(len(signals)):
                for c in range(len(windows)):
                    if np.isfinite(acc.iat[r, c]):
                        ax.text(c, r, f"{acc.iat[r, c]:.3f}\n{f1.iat[r, c]:.3f}",
                                ha="center", va="center", fontsize=7,
                                color="white" if acc.iat[r, c] < 0.8 else "black")
            ax.set_xticks(range(len(windows)), [f"{w:g} s" for w in windows], fontsize=7)
            ax.set_yticks(range(len(signals)), signals, fontsize=7)
            ax.set_title(f"{model} / {ds}", fontsize=8)
    fig.subplots_adjust(wspace=0.45, hspace=0.45)
    fig.colorbar(image, ax=axes, shrink=0.6, label=f"accuracy (k = {history})")
    fig.suptitle(f"mean over seeds, decision history k = {history}; text: accuracy / macro-F1",
                 fontsize=8)
    return fig


BACKENDS = ("loky", "dask", "ray")
#: Message of a ``ray`` backend asked for without the optional extra.
RAY_MISSING = "the ray backend needs the optional extra: pip install 'terrain[ray]'"
#: Message of a ``dask`` backend asked for where ``distributed`` is not installed.
DASK_MISSING = ("the dask backend needs dask's distributed scheduler (a dependency of "
                "terrain): pip install 'dask[distributed]'")


def check_backend(backend: str, address: str | None) -> None:
    """Refuse a backend and address that :func:`joblib_backend` would not use together.

    Parameters
    ----------
    backend : str
        ``loky``, ``dask`` or ``ray``.
    address : str or None
        Scheduler / cluster address.

    Raises
    ------
    ConfigError
        Unknown backend, an address with ``loky`` (local processes: the address would be
        ignored and the grid run here), ``ray`` without its optional extra installed, or
        ``dask`` without ``distributed``.
    """
    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend {backend!r}; valid: {list(BACKENDS)}")
    if backend == "dask" and importlib.util.find_spec("distributed") is None:
        raise ConfigError(DASK_MISSING)   # (Python's bare ModuleNotFoundError, in the run)
    if backend == "ray" and importlib.util.find_spec("ray") is None:
        raise ConfigError(RAY_MISSING)
    if backend == "loky" and address is not None:
        raise ConfigError(f"--address {address} needs --backend dask or ray: the loky backend "
                          "runs the grid in local processes and would ignore it")


@contextmanager
def joblib_backend(backend: str = "loky", address: str | None = None):
    """Route :class:`joblib.Parallel` calls to local processes, a Dask or a Ray cluster.

    Parameters
    ----------
    backend : {"loky", "dask", "ray"}
        ``loky``: local worker processes. ``dask``: a ``distributed.Client`` connected to
        ``address`` (``tcp://scheduler:8786``), or a local cluster when ``None``. ``ray``:
        ``ray.init(address)`` (optional extra ``terrain[ray]``), local when ``None``; a Ray
        session the caller already started is used as it is and left running.
    address : str or None
        Scheduler / cluster address.

    Yields
    ------
    int
        The ``n_jobs`` to pass to :class:`joblib.Parallel` (-1: every worker).

    Raises
    ------
    ConfigError
        Unknown backend, an address with ``loky`` (:func:`check_backend`), or the
        backend's library is not installed.
    """
    from joblib import parallel_config

    check_backend(backend, address)

    if backend == "loky":
        with parallel_config(backend="loky"):
            yield -1
    elif backend == "dask":
        from distributed import Client, LocalCluster

        cluster = None if address else LocalCluster(n_workers=2, threads_per_worker=1)
        try:   # the local cluster's worker processes are closed when a cell fails too
            with Client(address or cluster), parallel_config(backend="dask"):
                yield -1
        finally:
            if cluster is not None:
                cluster.close()
    else:                                   # ray (check_backend refused any other name)
        try:
            import ray
            from ray.util.joblib import register_ray
        except ImportError as exc:
            raise ConfigError(RAY_MISSING) from exc
        register_ray()
        started = not ray.is_initialized()   # a caller's own Ray session is used, and kept
        if started:
            ray.init(address=address)
        try:
            with parallel_config(backend="ray"):
                yield -1
        finally:
            if started:
                ray.shutdown()
