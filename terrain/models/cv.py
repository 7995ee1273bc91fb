"""Cross-validation protocols for terrain classification.

* ``grouped`` (the headline): ``StratifiedGroupKFold`` grouped by run, so no window of a
  test run, nor an overlapping neighbour of it, is ever in training. Scaling, class
  balancing and the nested hyperparameter search see training runs only.
* ``loro``: leave one run out.
* ``paper``: the published protocol of BorealTC (LaRocque et al., IROS 2024) and Vulpi et al.
  (J. Terramechanics 2021): each run cut into non-overlapping 5 s partitions,
  ``StratifiedKFold(5, shuffle=True, random_state=21)`` over partitions, 1.7 s windows sliding
  by 0.1 s inside each partition. Partitions of one run land on both sides of a split, so it
  leaks run conditions into the test folds: reported as a secondary line, never the headline.

A class with a single run (Vulpi DIRT_ROAD) cannot be tested on an unseen run. With
``single_run_blocks=k`` its run is cut into ``k`` contiguous time blocks used as groups (no
window crosses a block boundary, see :func:`purge_block_overlaps`); metrics of that class
then measure generalisation to an unseen stretch of the same run, which the report says.
"""

from __future__ import annotations

import inspect
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable, Iterator, Sequence

import numpy as np
import pandas as pd
from sklearn.base import clone
from sklearn.model_selection import LeaveOneGroupOut, StratifiedGroupKFold, StratifiedKFold

from terrain.errors import (ConfigError, ShapeError, config_integer, duplicated, first_items,
                            is_integer, listed, refuse_missing, refuse_mixed_types)
from terrain.models.metrics import confusion, run_majority_accuracy, window_metrics
from terrain.run import clock_slack

PROTOCOLS = ("grouped", "loro", "paper")
PAPER_RANDOM_STATE = 21


def split_single_run_classes(labels: np.ndarray, groups: np.ndarray, t_start_s: np.ndarray,
                             n_blocks: int) -> tuple[np.ndarray, list[str]]:
    """Cut the only run of single-run classes into contiguous time blocks.

    Parameters
    ----------
    labels, groups, t_start_s : numpy.ndarray
        ``(n_windows,)`` label, group (run id) and start time (s) of each window.
    n_blocks : int
        Blocks per single-run class (>= 2). A class with fewer windows gets one block per
        window (no empty block): count them in the returned groups.

    Returns
    -------
    groups : numpy.ndarray
        ``(n_windows,)`` new groups: ``<run>@block<k>`` for the split classes.
    split_classes : list of str
        Classes that were split.

    Raises
    ------
    ConfigError
        ``n_blocks`` not an integer >= 2 (0 reached NumPy's bare "number sections must be
        larger than 0"; 1 or ``True`` left the class one block, never trained on when tested);
        a block's name ``<run>@block<k>`` already the id of another run (the two were made
        one split unit).
    """
    config_integer("n_blocks", n_blocks, 2)
    groups = groups.astype(object).copy()
    cut = np.zeros(len(groups), dtype=bool)      # windows of a class cut into blocks
    split = []
    for c in np.unique(labels):
        sel = labels == c
        runs = np.unique(groups[sel])
        if len(runs) != 1:
            continue
        split.append(str(c))
        idx = np.flatnonzero(sel)
        order = idx[np.argsort(t_start_s[idx], kind="stable")]
        for k, chunk in enumerate(np.array_split(order, n_blocks)):
            groups[chunk] = f"{runs[0]}@block{k}"
        cut[idx] = True
    # a block named as another run made the two one split unit: renaming a run to
    # '<run>@block0' changed the folds without a word
    clash = sorted(set(groups[cut].tolist()) & set(groups[~cut].tolist()), key=str)
    if clash:
        raise ConfigError(f"split_single_run_classes: the time block(s) {clash} of a "
                          "single-run class are also the id of another run (blocks are named "
                          "'<run>@block<k>'): rename that run")
    return groups, split


def purge_block_overlaps(groups: np.ndarray, run_ids: np.ndarray, t_start_s: np.ndarray,
                         t_end_s: np.ndarray) -> np.ndarray:
    """Keep-mask that removes windows overlapping another split unit of the same run.

    With overlapping windows (hop < window), the last windows of a time block of a run
    overlap the first windows of the next block. Each such straddling window (it ends after
    the start of the next block of its run) is dropped, so no test window shares samples
    with a training window.

    Parameters
    ----------
    groups, run_ids, t_start_s, t_end_s : numpy.ndarray
        ``(n_windows,)`` split unit, run id and window bounds (s).

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)`` bool, True for windows to keep.
    """
    keep = np.ones(len(groups), dtype=bool)
    for run in np.unique(run_ids):
        sel = np.flatnonzero(run_ids == run)
        units = np.unique(groups[sel])
        if len(units) < 2:
            continue
        starts = sorted(float(t_start_s[sel][groups[sel] == u].min()) for u in units)
        for boundary in starts[1:]:
            keep[sel[(t_start_s[sel] < boundary)
                     & (t_end_s[sel] > boundary + clock_slack(boundary))]] = False
    return keep


def grouped_units(ws, n_blocks: int) -> tuple:
    """Windows, labels and split units of the run-grouped protocols, as ``terrain cv`` cuts them.

    Single-run classes are cut into ``n_blocks`` contiguous time blocks used as groups
    (:func:`split_single_run_classes`) and windows straddling a block boundary are dropped
    (:func:`purge_block_overlaps`).

    Parameters
    ----------
    ws : features.windows.WindowSet
        Windows with ``labels``, ``groups`` (run ids), ``run_ids`` and bounds (s).
    n_blocks : int
        Blocks per single-run class (>= 2).

    Returns
    -------
    ws : features.windows.WindowSet
        The kept windows.
    labels : numpy.ndarray
        ``(n_kept,)`` class names (str).
    groups : numpy.ndarray
        ``(n_kept,)`` split units (runs, or ``<run>@block<k>`` of a split class).
    split_classes : list of str
        Classes that were cut into blocks.
    n_dropped : int
        Windows dropped for straddling a block boundary.

    Raises
    ------
    ConfigError
        ``n_blocks`` not an integer >= 2, or a block named as another run
        (:func:`split_single_run_classes`).
    """
    labels = ws.labels.astype(str)
    groups, split = split_single_run_classes(labels, ws.groups, ws.t_start_s, n_blocks)
    keep = purge_block_overlaps(groups, ws.run_ids, ws.t_start_s, ws.t_end_s)
    if keep.all():  # no copy of the windows when nothing is dropped
        return ws, labels, groups, split, 0
    return ws.subset(keep), labels[keep], groups[keep], split, int((~keep).sum())


def block_notes(labels: np.ndarray, groups: np.ndarray, split_classes: Sequence[str],
                n_blocks: int, n_dropped: int) -> list[str]:
    """What :func:`grouped_units` changed, as ``terrain cv`` and ``terrain compare`` say it.

    Parameters
    ----------
    labels, groups : numpy.ndarray
        ``(n_kept,)`` class names and split units of the kept windows.
    split_classes : sequence of str
        Classes cut into time blocks.
    n_blocks : int
        Blocks asked per single-run class.
    n_dropped : int
        Windows dropped for straddling a block boundary.

    Returns
    -------
    list of str
        One note per split class (with a warning where it got fewer than 2 blocks, so it is
        never in training when tested) and one for the dropped windows; empty when nothing
        was cut.
    """
    notes = []
    for c in split_classes:
        # a class with fewer windows than blocks gets fewer (non-empty) blocks
        n_units = len(np.unique(groups[labels == c]))
        note = (f"class {c} has a single run: cut into {n_units} contiguous time "
                f"block(s) (of {n_blocks} asked) used as groups (its "
                f"scores measure an unseen stretch of the same run, not an unseen run)")
        if n_units < 2:
            note += (f"; WARNING: with fewer than 2 blocks, {c} is never in training "
                     f"when it is tested (its recall is 0 by construction): its scores "
                     f"do not measure generalisation")
        notes.append(note)
    if n_dropped:
        notes.append(f"{n_dropped} window(s) straddling a time-block boundary dropped")
    return notes


def training_units(run_ids: np.ndarray, t_start_s: np.ndarray, t_end_s: np.ndarray,
                   groups: np.ndarray, train_run_ids: np.ndarray, train_t_start_s: np.ndarray,
                   train_t_end_s: np.ndarray) -> np.ndarray:
    """Split unit of every window of a denser training cut of the same runs.

    The evaluation windows (one set, with their split units) define the folds; training may
    use more, overlapping windows cut from the same runs at a finer hop. Each such window
    belongs to the unit of its run when the run is one unit. When a run is cut into time
    blocks (a single-run class), it belongs to the one block whose evaluation windows it
    overlaps; a window overlapping two blocks or none, and every window of a run without
    evaluation windows, gets no unit (``None``) and is never trained on. So a training window
    never shares a sample with a test window of another unit.

    Parameters
    ----------
    run_ids, t_start_s, t_end_s, groups : numpy.ndarray
        ``(n_windows,)`` run, bounds (s) and split unit of the evaluation windows.
    train_run_ids, train_t_start_s, train_t_end_s : numpy.ndarray
        ``(n_train_windows,)`` run and bounds (s) of the training cut.

    Returns
    -------
    numpy.ndarray
        ``(n_train_windows,)`` object array of units, ``None`` where unusable.
    """
    run_ids, groups = np.asarray(run_ids), np.asarray(groups, dtype=object)
    train_run_ids = np.asarray(train_run_ids)
    units = np.full(len(train_run_ids), None, dtype=object)
    for run in np.unique(train_run_ids):
        dense = np.flatnonzero(train_run_ids == run)
        own = np.flatnonzero(run_ids == run)
        run_units = np.unique(groups[own])
        if len(run_units) == 1:
            units[dense] = run_units[0]
            continue
        for i in dense:
            hit = own[(t_start_s[own] < train_t_end_s[i] - clock_slack(train_t_end_s[i]))
                      & (t_end_s[own] > train_t_start_s[i] + clock_slack(train_t_start_s[i]))]
            hit_units = np.unique(groups[hit])
            if len(hit_units) == 1:
                units[i] = hit_units[0]
    return units


@dataclass(frozen=True)
class TrainingWindows:
    """A denser training cut of the cross-validated runs (see :func:`training_units`).

    Parameters
    ----------
    X : numpy.ndarray
        ``(n_train_windows, ...)`` model input (features or raw windows).
    y : numpy.ndarray
        ``(n_train_windows,)`` labels.
    units : numpy.ndarray
        ``(n_train_windows,)`` split unit of each window (``None``: never trained on).

    Raises
    ------
    ShapeError
        ``X``, ``y`` and ``units`` not of one length.
    """

    X: np.ndarray
    y: np.ndarray
    units: np.ndarray

    def __post_init__(self) -> None:
        # (parts of other lengths failed in every fold of cross_validate with a bare
        # IndexError, after the folds before it were fitted)
        lengths = {name: (value.shape[0] if hasattr(value, "shape") else len(value))
                   for name, value in (("X", self.X), ("y", self.y), ("units", self.units))}
        if len(set(lengths.values())) > 1:
            raise ShapeError(f"TrainingWindows: X, y and units must hold one entry per "
                             f"training window, got lengths {lengths}")

    def rows_of(self, train_units) -> np.ndarray:
        """Indices of the windows whose unit is among ``train_units``.

        Parameters
        ----------
        train_units : array-like
            Split units of a training fold.

        Returns
        -------
        numpy.ndarray
            Integer indices into :attr:`X`.
        """
        wanted = set(np.asarray(train_units, dtype=object).tolist())
        return np.flatnonzero([u is not None and u in wanted for u in self.units])


def refuse_units_within_runs(owner: str, labels, groups, run_ids) -> None:
    """Refuse split units that cut a run of a class with several runs.

    The run-grouped protocols (``grouped``, ``loro``) estimate how a model does on unseen
    runs: every window of a run must then be in one split unit, so that a run is never on
    both sides of a split. The only exception is the time blocks of a single-run class
    (:func:`split_single_run_classes`): its windows of that run may span several units.
    Units coarser than a run (several runs in one) are honest and accepted.

    Parameters
    ----------
    owner : str
        Caller, for the message.
    labels, groups, run_ids : numpy.ndarray
        ``(n_windows,)`` class, split unit and run of every window.

    Raises
    ------
    ConfigError
        A run whose windows of one class (that class having more than one run) lie in more
        than one split unit; the message names the run, its class and units (windows or
        5 s partitions given as ``groups`` made folds with one run on both sides).
    """
    frame = pd.DataFrame({"y": np.asarray(labels), "g": np.asarray(groups, dtype=object),
                          "r": np.asarray(run_ids, dtype=object)})
    runs_of_class = frame.groupby("y")["r"].nunique()
    units = frame.groupby(["y", "r"], sort=True)["g"].nunique()
    bad = units[(units > 1).to_numpy()
                & (runs_of_class.loc[units.index.get_level_values("y")] > 1).to_numpy()]
    if len(bad):
        c, run = bad.index[0]
        shown = listed(sorted(set(frame.loc[(frame["y"] == c) & (frame["r"] == run),
                                            "g"].tolist()), key=str))
        raise ConfigError(f"{owner}: the run-grouped protocols split by run, but groups cut "
                          f"{len(bad)} run(s) of classes with several runs into several split "
                          f"units, e.g. run {run!r} of class {c!r} into {bad.iloc[0]} units "
                          f"({shown}): its windows would be on both sides of a split; give "
                          "each window its run id as its group (only a single-run class is "
                          "cut into time blocks, split_single_run_classes), or use the "
                          "'paper' protocol for partitions")


def iter_splits(protocol: str, labels: np.ndarray, groups: np.ndarray, seed: int,
                n_splits: int = 5) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Train/test window indices of one protocol.

    Parameters
    ----------
    protocol : {"grouped", "loro", "paper"}
        ``StratifiedGroupKFold`` by group, leave one group out, or the published
        ``StratifiedKFold`` over 5 s partitions (see the module docstring).
    labels, groups : numpy.ndarray
        ``(n_windows,)``; for ``paper`` the groups are the 5 s partitions.
    seed : int
        Shuffling seed (``paper`` uses ``(21 + seed) mod 2**32``, NumPy's seed range, so
        seed 0 is the published split).
    n_splits : int
        Folds (not used by ``loro``).

    Yields
    ------
    train, test : numpy.ndarray
        ``(n_train,)`` and ``(n_test,)`` integer indices into the windows, one pair per
        fold; no group is on both sides.

    Raises
    ------
    ConfigError
        ``seed`` (``grouped``, ``paper``) not an integer in [0, 2**32 - 1], ``n_splits``
        (``grouped``, ``paper``) not an integer,
        unknown protocol, more folds than groups, every class with fewer windows
        (``grouped``) or 5 s partitions (``paper``) than folds, which the stratified
        splitters refuse (``grouped``, ``paper``), a ``grouped`` split that leaves a fold
        without a test unit (few runs), or ``loro`` over fewer than 2 runs.
    ShapeError
        ``labels`` and ``groups`` not of one length.
    NonFiniteInputError
        A missing run (NaN or None) in ``groups``: ``grouped`` made one split unit of every
        such window (NumPy's ``unique`` counts NaN once).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``labels`` or
        ``groups`` (:func:`terrain.errors.refuse_mixed_types`).
    """
    if len(labels) != len(groups):     # scikit-learn's "inconsistent numbers of samples"
        raise ShapeError(f"iter_splits: labels ({len(labels)}) and groups ({len(groups)}) "
                         "must hold one entry per window")
    refuse_missing("iter_splits", "groups", groups, "run(s)",
                   "every window needs its split unit")
    for name, values in (("labels", labels), ("groups", groups)):
        refuse_mixed_types("iter_splits", name, values)   # (NumPy's bare "'<' not supported")
    if protocol in ("grouped", "paper"):
        # NumPy's bare "Seed must be between 0 and 2**32 - 1" (grouped), or a seed taken
        # modulo 2**32 without a word (paper: -1 was 20, 2**32 the published split)
        config_integer("seed", seed, 0, 2 ** 32 - 1)
        if not is_integer(n_splits):   # scikit-learn's "must be of Integral type"
            raise ConfigError(f"n_splits must be an integer, got {n_splits!r}")
    n_groups = len(np.unique(groups))
    if protocol in ("grouped", "paper") and not 2 <= n_splits <= n_groups:
        units = ("runs, or blocks of a single-run class" if protocol == "grouped"
                 else "5 s partitions")
        raise ConfigError(f"{n_splits} folds over {n_groups} split units ({units}): every "
                          "fold holds at least one unit out, and there are at least 2 folds")
    if protocol in ("grouped", "paper"):
        # scikit-learn's stratified splitters raise a bare ValueError when no class has as
        # many members (windows; partitions for the paper protocol) as there are folds
        members = (labels if protocol == "grouped"
                   else labels[np.unique(groups, return_index=True)[1]])
        _, counts = np.unique(members, return_counts=True)
        if (counts < n_splits).all():
            what = "windows" if protocol == "grouped" else "5 s partitions"
            raise ConfigError(f"{n_splits} folds, and no class has as many {what} (at most "
                              f"{counts.max()}): use shorter windows or fewer folds")
    if protocol == "grouped":
        splits = list(StratifiedGroupKFold(n_splits, shuffle=True, random_state=seed).split(
            labels, labels, groups))
        empty = [k for k, (_, test) in enumerate(splits) if not len(test)]
        if empty:
            # with few runs the splitter can leave a fold with no test run (the fit on it then
            # failed with scikit-learn's bare "Found array with 0 sample(s)")
            raise ConfigError(f"StratifiedGroupKFold({n_splits}, seed {seed}) puts no test run "
                              f"in fold(s) {empty} of {n_groups} split units: use fewer folds "
                              "or more runs")
        yield from splits
    elif protocol == "loro":
        if n_groups < 2:      # scikit-learn's bare ValueError otherwise
            raise ConfigError(f"leave one run out needs at least 2 runs, got {n_groups} "
                              f"({listed(np.unique(groups).tolist())})")
        yield from LeaveOneGroupOut().split(labels, labels, groups)
    elif protocol == "paper":
        units, first = np.unique(groups, return_index=True)
        unit_labels = labels[first]
        skf = StratifiedKFold(n_splits, shuffle=True,
                              random_state=(PAPER_RANDOM_STATE + seed) % 2 ** 32)
        position = {u: i for i, u in enumerate(units)}
        unit_of = np.array([position[g] for g in groups])
        for tr_u, te_u in skf.split(units, unit_labels):
            test = np.isin(unit_of, te_u)
            yield np.flatnonzero(~test), np.flatnonzero(test)
    else:
        raise ConfigError(f"unknown protocol {protocol!r}; valid: {list(PROTOCOLS)}")


@dataclass
class CVReport:
    """Result of a cross-validation.

    Attributes
    ----------
    classes : list of str
        Sorted class labels of the windows.
    folds : pandas.DataFrame
        One row per (seed, fold): window metrics, ``run_majority_accuracy``, ``n_test``,
        ``n_train`` (windows trained on), ``fit_s`` and the chosen hyperparameters when a
        search ran.
        ``run_majority_accuracy`` votes per split unit: the run under ``grouped``/``loro``
        (a time block for a single-run class), the 5 s partition under ``paper``.
    predictions : pandas.DataFrame
        One row per test window and seed: ``seed, fold, run, group, t_start_s, t_end_s,
        true, predicted``.
    confusion : pandas.DataFrame
        Counts summed over seeds (rows true, columns predicted).
    pooled : pandas.DataFrame
        Metrics of the pooled out-of-fold predictions, one row per seed.
    notes : list of str
        What was repaired, split or skipped.
    """

    classes: list[str]
    folds: pd.DataFrame
    predictions: pd.DataFrame
    confusion: pd.DataFrame
    pooled: pd.DataFrame
    notes: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, dict[str, float | int]]:
        """Mean, std, min and max over folds (all seeds) of every metric, and how many
        folds that is.

        Returns
        -------
        dict
            Metric name (each float column of :attr:`folds` but ``seed``/``fold``) ->
            ``{"mean", "std" (population, ddof=0), "min", "max", "n_folds"}``: over the
            folds with a value, ``n_folds`` of them (for ``recall_<CLASS>``, the folds whose
            test windows hold the class; every fold for the other metrics).
        """
        cols = [c for c in self.folds.columns if c not in ("seed", "fold")
                and self.folds[c].dtype.kind == "f"]
        return {c: {"mean": float(self.folds[c].mean()), "std": float(self.folds[c].std(ddof=0)),
                    "min": float(self.folds[c].min()), "max": float(self.folds[c].max()),
                    "n_folds": int(self.folds[c].notna().sum())}
                for c in cols}


def require_runs(groups, n_splits, purpose: str, setting: str,
                 alternatives: Sequence[str] = (), labels=None) -> None:
    """Refuse an inner split by run into more folds than there are runs, or (``labels``
    given) than the largest class has windows.

    scikit-learn's own errors ("Cannot have number of splits n_splits=5 greater than the
    number of groups: 3"; "n_splits=4 cannot be greater than the number of members in each
    class") name neither the runs nor the setting; this one names both.

    Parameters
    ----------
    groups : array-like or None
        ``(n_windows,)`` run of every training window; ``None``: no runs given.
    n_splits : int
        Inner folds asked for (``StratifiedGroupKFold(n_splits)``).
    purpose : str
        What splits, for the message (e.g. ``"early stopping"``).
    setting : str
        The setting that gives ``n_splits`` (e.g. ``"SVMConfig.inner_splits"``).
    alternatives : sequence of str
        Other remedies named after "more runs or fewer <setting>" (e.g.
        ``"early_stopping=False"``).
    labels : array-like or None
        ``(n_windows,)`` class of every training window, for a stratified split
        (``StratifiedGroupKFold``, which refuses a split where every class has fewer
        windows than folds); ``None``: not checked.

    Raises
    ------
    ConfigError
        ``n_splits`` not an integer >= 2, fewer runs than ``n_splits`` (the message names
        the runs, the first three and a count), or ``labels`` whose every class has fewer
        windows than ``n_splits``.
    NonFiniteInputError
        A run in ``groups`` is missing (NaN or None); the message names the first window.
    ShapeError
        ``groups`` not 1-D, or (``labels`` given) not of the length of ``labels``.
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``groups`` or
        ``labels`` (:func:`terrain.errors.refuse_mixed_types`).
    """
    config_integer(setting, n_splits, 2)
    if groups is not None:
        # (scikit-learn's "inconsistent numbers of samples" named neither; a 2-D groups
        # failed as an unhashable list)
        shape = np.shape(groups)
        if len(shape) != 1 or (labels is not None and np.shape(labels)[:1] != shape):
            also = "" if labels is None else f" as the labels {np.shape(labels)}"
            raise ShapeError(f"{purpose}: groups {shape} must be 1-D, one run per training "
                             f"window{also}")
        # every NaN is a new object: a set counted one run per missing window
        refuse_missing(purpose, "groups", groups, "run(s)", "every window needs its run")
        refuse_mixed_types(purpose, "groups", groups)
    if labels is not None:
        refuse_mixed_types(purpose, "labels", labels)
    runs = [] if groups is None else sorted(set(np.asarray(groups).tolist()), key=str)
    if len(runs) < n_splits:
        given = first_items(runs, word="run") if runs else "no groups given"
        remedies = ["more runs", f"fewer {setting.rsplit('.', 1)[-1]} (>= 2)", *alternatives]
        raise ConfigError(f"{purpose} splits its training windows by run into {n_splits} "
                          f"inner folds ({setting}): it got {len(runs)} runs ({given}) and "
                          f"needs at least {n_splits}; give {', '.join(remedies[:-1])} or "
                          f"{remedies[-1]}")
    if labels is not None:
        _, counts = np.unique(np.asarray(labels), return_counts=True)
        if counts.size and (counts < n_splits).all():
            remedies = ["more windows", f"fewer {setting.rsplit('.', 1)[-1]} (>= 2)",
                        *alternatives]
            raise ConfigError(f"{purpose} splits its training windows by run into {n_splits} "
                              f"stratified inner folds ({setting}): no class has {n_splits} "
                              f"windows (at most {counts.max()}); give "
                              f"{', '.join(remedies[:-1])} or {remedies[-1]}")


def class_keeping_split(labels, groups, n_splits: int, random_state: int, purpose: str,
                        setting: str, alternative: str) -> tuple[np.ndarray, np.ndarray]:
    """Training and held-out rows of an inner split by run that keeps every class trained.

    The first split of ``StratifiedGroupKFold(n_splits, shuffle=True, random_state)`` whose
    held-out runs are not empty and whose training runs hold every class: a class of one run
    would otherwise be held out whole, validated on but never trained on. The same split as
    the first one whenever that one keeps every class.

    Parameters
    ----------
    labels, groups : array-like
        ``(n_windows,)`` class and run of every training window.
    n_splits : int
        ``1 / n_splits`` of the runs are held out.
    random_state : int
        Seed of the split's shuffling.
    purpose : str
        What the runs are held out for, for the messages (e.g. ``"early stopping"``).
    setting : str
        The setting that gives ``n_splits`` (e.g. ``"validation_splits"``).
    alternative : str
        A remedy besides more runs and fewer splits (e.g. ``"early_stopping=False"``).

    Returns
    -------
    fit_idx, held_idx : numpy.ndarray
        Integer rows of the training and the held-out windows.

    Raises
    ------
    ConfigError
        Fewer runs than ``n_splits``, ``n_splits`` not an integer >= 2 or every class with
        fewer windows than ``n_splits`` (:func:`require_runs`), ``random_state`` not an
        integer in [0, 2**32 - 1], or no split that keeps a training run of every class (the
        message names the classes held out whole).
    NonFiniteInputError
        A missing run (:func:`require_runs`).
    ShapeError
        ``groups`` not 1-D or of another length than ``labels`` (:func:`require_runs`).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``labels`` or
        ``groups`` (:func:`require_runs`) (:func:`terrain.errors.refuse_mixed_types`).
    """
    require_runs(groups, n_splits, purpose, setting, (alternative,), labels)
    # (NumPy's bare "Seed must be between 0 and 2**32 - 1" otherwise)
    config_integer("random_state", random_state, 0, 2 ** 32 - 1)
    classes, y_idx = np.unique(np.asarray(labels), return_inverse=True)
    inner = StratifiedGroupKFold(n_splits, shuffle=True, random_state=random_state)
    lost = set()
    for fit_idx, held_idx in inner.split(y_idx, y_idx, np.asarray(groups)):
        missing = np.setdiff1d(np.arange(len(classes)), y_idx[fit_idx])
        if held_idx.size and not missing.size:
            return fit_idx, held_idx
        lost.update(classes[missing].tolist())
    raise ConfigError(f"{purpose} holds 1/{n_splits} of the training runs out, and every "
                      f"such split (seed {random_state}) holds out every run of class(es) "
                      f"{sorted(lost)}: give those classes more runs, fewer {setting}, or "
                      f"{alternative}")


def fit_with_groups(estimator, X, y, groups, always: bool = False, **fit_params):
    """Fit, passing ``groups`` to estimators whose ``fit`` takes it (searches, ensembles, CNNs).

    Parameters
    ----------
    estimator : estimator
        Unfitted scikit-learn estimator.
    X : array-like
        ``(n_windows, ...)`` its input.
    y, groups : numpy.ndarray
        ``(n_windows,)`` labels and split units (runs) of the training windows.
    always : bool
        Pass ``groups`` even if ``fit`` does not name it (``GridSearchCV.fit(**params)``).
    **fit_params : dict
        Further fit parameters, passed as they are (e.g. ``svc__sample_weight``).

    Returns
    -------
    estimator
        The fitted estimator.
    """
    if groups is not None and (always
                               or "groups" in inspect.signature(estimator.fit).parameters):
        return estimator.fit(X, y, groups=groups, **fit_params)
    return estimator.fit(X, y, **fit_params)


@contextmanager
def restored_on_failure(model) -> Iterator[None]:
    """Put ``model``'s attributes back as they were when the block inside raises.

    A ``fit`` that sets some fitted attributes (``classes_``, a scaling) before it refuses
    its input would otherwise leave them beside the previous fit's (a network trained on
    other classes now read under the new labels); with this block around it, a refused or
    interrupted fit leaves the model as it was: unfitted, or its previous fit whole.

    Parameters
    ----------
    model : estimator
        The estimator being fitted (its instance attributes are restored; parameters set
        before the block are kept as they were set).

    Yields
    ------
    None
    """
    previous = dict(vars(model))
    try:
        yield
    except BaseException:
        vars(model).clear()
        vars(model).update(previous)
        raise


def inference_ms_per_window(estimator, X: np.ndarray, n_windows: int) -> float:
    """Median latency of one window's prediction (batch of 1), ms.

    Parameters
    ----------
    estimator : classifier
        Fitted; ``predict_proba`` is timed when it exists, else ``predict``.
    X : numpy.ndarray
        ``(n, ...)`` input windows; the first ``n_windows`` are timed one by one.
    n_windows : int
        Windows timed (after one untimed warm-up call).

    Returns
    -------
    float
        Median wall time per call, ms.

    Raises
    ------
    ConfigError
        ``n_windows`` not an integer >= 1, or ``X`` holds no window (nothing timed: the
        median of no time was NaN with a NumPy warning).
    """
    config_integer("inference_ms_per_window n_windows", n_windows, 1)
    if not len(X):
        raise ConfigError("inference_ms_per_window: no window to time (X is empty)")
    call = getattr(estimator, "predict_proba", None) or estimator.predict
    try:
        call(X[:1])
    except AttributeError:  # an SVC without probability estimates
        call = estimator.predict
        call(X[:1])
    times = []
    for i in range(min(n_windows, len(X))):
        t0 = time.perf_counter()
        call(X[i:i + 1])
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def member_probabilities(proba) -> np.ndarray:
    """A classifier's class probabilities in float64, each row divided by its own sum.

    Members whose probabilities are float32 (MiniRocket's logistic regression on float32
    features) hand out rows summing to 1 within ~1e-7 only; averaged or scored in float64
    (an ensemble, a cross-validation frame), that is outside scikit-learn's tolerance
    (the square root of float64's eps), and ``log_loss`` warns "The y_prob values do not sum
    to one". Renormalised in float64, the rows sum to 1 within a few float64 eps; a row
    that already does moves by as much, and the ranking of a row's classes is kept. A row
    summing to 0 (no probability at all) is left as it is.

    Parameters
    ----------
    proba : array-like
        ``(n_windows, n_classes)`` non-negative class probabilities (``predict_proba``).

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_classes)`` float64, a new array.
    """
    out = np.array(proba, dtype=np.float64)
    total = out.sum(axis=1, keepdims=True)
    np.divide(out, total, out=out, where=total > 0)
    return out


def _fold(estimator, X_fit, y_fit, groups_fit, fit_rows, X, test, classes, search,
          time_inference):
    """Fit on rows ``fit_rows`` of ``X_fit``, predict rows ``test`` of ``X``; (predictions,
    probabilities or None, fit s, best parameters (plus ``n_epochs`` run by a CNN), inference
    ms per window or None)."""
    t0 = time.perf_counter()
    est = fit_with_groups(estimator, X_fit[fit_rows], y_fit[fit_rows], groups_fit[fit_rows],
                          always=search)
    fit_s = time.perf_counter() - t0
    infer_ms = (inference_ms_per_window(est, X[test], time_inference) if time_inference
                else None)
    proba = None
    if hasattr(est, "predict_proba"):
        try:
            raw = est.predict_proba(X[test])
        except AttributeError:  # e.g. an SVC without probability estimates
            raw = None
        if raw is not None:
            raw = member_probabilities(raw)
            proba = np.zeros((len(test), len(classes)))
            for j, c in enumerate(est.classes_):
                proba[:, classes.index(str(c))] = raw[:, j]
    p = np.asarray(est.predict(X[test])).astype(str)
    best = dict(getattr(est, "best_params_", None) or {})
    if hasattr(est, "n_epochs_"):
        best["n_epochs"] = float(est.n_epochs_)
    return p, proba, fit_s, best, infer_ms


def cross_validate(estimator_factory: Callable[[int], object], X: np.ndarray, y: np.ndarray,
                   groups: np.ndarray, run_ids: np.ndarray, t_start_s: np.ndarray,
                   t_end_s: np.ndarray, protocol: str = "grouped",
                   seeds: Sequence[int] = (0, 1, 2), n_splits: int = 5,
                   search: bool = False, progress: bool = False,
                   n_jobs: int | None = None, time_inference: int = 0,
                   training: TrainingWindows | None = None) -> CVReport:
    """Cross-validate a classifier on window features or raw windows.

    Folds of every seed are independent tasks run through :class:`joblib.Parallel`, so the
    active joblib backend (``joblib.parallel_config(backend="dask")`` etc.) decides where
    they run.

    Parameters
    ----------
    estimator_factory : callable
        ``seed -> estimator``; a fresh estimator per fold (``clone`` is applied too).
        Estimators whose ``fit`` takes ``groups`` (a grouped search, the ensemble, the CNNs)
        receive the training split units.
    X : numpy.ndarray
        ``(n_windows, n_features)`` or raw windows ``(n_windows, n_channels, n_samples)``.
    y, groups, run_ids, t_start_s, t_end_s : numpy.ndarray
        ``(n_windows,)`` label, split unit, run id and window bounds (s).
    protocol : {"grouped", "loro", "paper"}
        Split protocol, see :func:`iter_splits`.
    seeds : sequence of int
        Split (and model) seeds.
    n_splits : int
        Folds (not used by ``loro``).
    search : bool
        Always pass the training groups to ``fit`` (nested, grouped hyperparameter search).
    progress : bool
        Show a progress bar over folds (sequential runs only).
    n_jobs : int or None
        joblib workers over folds (``None``: sequential unless a backend context says).
    time_inference : int
        When > 0, time that many test windows one by one per fold
        (``infer_ms_per_window`` column of ``folds``).
    training : TrainingWindows or None
        Train each fold on the windows of this denser cut whose unit is a training unit of
        the fold, instead of the training windows of ``X``; the folds and the test windows
        are those of ``X`` either way. ``None``: train on ``X``'s own windows.

    Returns
    -------
    CVReport
        ``predictions`` carries ``proba_<CLASS>`` columns when the model gives
        probabilities.

    Raises
    ------
    ConfigError
        Unknown ``protocol``, or folds :func:`iter_splits` refuses; ``seeds`` empty, repeated
        or not integers in [0, 2**32 - 1]; ``time_inference`` not an integer >= 0;
        ``training`` holding windows with a unit of a class that no window of ``y`` holds;
        under ``grouped`` or ``loro``, ``groups`` that cut a run of a class with several
        runs into several units (windows or partitions as groups put one run on both sides
        of a split: :func:`refuse_units_within_runs`).
    ShapeError
        ``X``, ``groups``, ``run_ids``, ``t_start_s`` or ``t_end_s`` not one entry per label.
    NonFiniteInputError
        A label is missing (NaN or None; it would be scored as a class of its own).
    RuntimeError
        If a split unit lands on both sides of a split (an internal invariant; it signals a
        bug, not bad input).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``y``,
        ``groups`` or ``run_ids`` (1 and "1" were made one class)
        (:func:`terrain.errors.refuse_mixed_types`).
    """
    from joblib import Parallel, delayed

    y = np.asarray(y)
    refuse_missing("cross_validate", "y", y, "label(s)")  # astype(str): the class "nan"
    # (astype(str) made 1 and "1" one class; mixed groups failed in NumPy's sort)
    for name, values in (("y", y), ("groups", groups), ("run_ids", run_ids)):
        refuse_mixed_types("cross_validate", name, values)
    for name, values in (("X", X), ("groups", groups), ("run_ids", run_ids),
                         ("t_start_s", t_start_s), ("t_end_s", t_end_s)):
        n = values.shape[0] if hasattr(values, "shape") else len(values)   # (sparse X)
        if n != len(y):
            raise ShapeError(f"cross_validate: {name} holds {n} entries for {len(y)} labels "
                             "(y): one per window")
    y = y.astype(str)
    if protocol in ("grouped", "loro"):
        refuse_units_within_runs("cross_validate", y, groups, run_ids)
    # no seed reached pandas' "No objects to concatenate"; a repeated one counted one split
    # twice; a negative time_inference gave a column of NaN, 2.5 a bare TypeError
    seeds = tuple(seeds)
    if not seeds or duplicated(seeds):
        raise ConfigError(f"cross_validate: seeds must be one or more distinct integers, got "
                          f"{list(seeds)}")
    for seed in seeds:
        config_integer("seeds", seed, 0, 2 ** 32 - 1)
    config_integer("time_inference", time_inference, 0)
    classes = sorted(np.unique(y))
    if training is not None:
        # (a fold's model knew the class and the mapping of its probabilities onto the
        # evaluation classes raised a bare "'C' is not in list")
        # (windows without a unit are never trained on: their classes do not matter)
        used = np.array([u is not None for u in training.units], dtype=bool)
        extra = sorted(set(np.asarray(training.y)[used].astype(str).tolist()) - set(classes))
        if extra:
            raise ConfigError(f"cross_validate: the training cut holds trainable windows of "
                              f"class(es) {extra} that no evaluation window holds (classes "
                              f"{classes}): cut both from the same runs and labels")
    tasks = []
    for seed in seeds:
        for fold, (train, test) in enumerate(iter_splits(protocol, y, groups, seed, n_splits)):
            if np.intersect1d(groups[train], groups[test]).size:
                raise RuntimeError("a split unit is on both sides of a split")  # invariant
            tasks.append((seed, fold, train, test))
    if training is None:
        fit_on = (X, y, groups)
        fit_rows = [train for _, _, train, _ in tasks]
    else:
        fit_on = (training.X, np.asarray(training.y).astype(str), training.units)
        fit_rows = [training.rows_of(np.unique(groups[train])) for _, _, train, _ in tasks]
    jobs = (delayed(_fold)(clone(estimator_factory(seed)), *fit_on, fit_idx, X, test, classes,
                           search, time_inference)
            for (seed, _, _, test), fit_idx in zip(tasks, fit_rows))
    if progress and n_jobs in (None, 1):
        from tqdm.auto import tqdm
        jobs = tqdm(jobs, total=len(tasks), desc=f"cv ({protocol})", unit="fold")
    results = Parallel(n_jobs=n_jobs)(jobs)
    rows, preds = [], []
    for (seed, fold, _, test), fit_idx, (p, proba, fit_s, best, infer_ms) in zip(
            tasks, fit_rows, results):
        m = window_metrics(y[test], p, classes)
        m["run_majority_accuracy"] = run_majority_accuracy(y[test], p, groups[test])
        row = {"seed": seed, "fold": fold, **m, "n_test": float(len(test)),
               "n_train": float(len(fit_idx)), "fit_s": fit_s}
        if infer_ms is not None:
            row["infer_ms_per_window"] = infer_ms
        if best:
            epochs = best.pop("n_epochs", None)
            row.update({f"best_{k}": v for k, v in best.items()})
            if epochs is not None:
                row["n_epochs"] = epochs
        rows.append(row)
        frame = pd.DataFrame({
            "seed": seed, "fold": fold, "run": run_ids[test], "group": groups[test],
            "t_start_s": t_start_s[test], "t_end_s": t_end_s[test], "true": y[test],
            "predicted": p})
        if proba is not None:
            for j, c in enumerate(classes):
                frame[f"proba_{c}"] = proba[:, j]
        preds.append(frame)
    predictions = pd.concat(preds, ignore_index=True)
    pooled = []
    for seed, g in predictions.groupby("seed"):
        m = window_metrics(g["true"], g["predicted"], classes)
        m["run_majority_accuracy"] = run_majority_accuracy(g["true"], g["predicted"], g["group"])
        pooled.append({"seed": seed, **m})
    cm = confusion(predictions["true"], predictions["predicted"], classes)
    return CVReport(classes, pd.DataFrame(rows), predictions, cm, pd.DataFrame(pooled))
