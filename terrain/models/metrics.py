"""Classification metrics for terrain windows and runs."""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd
from sklearn.metrics import accuracy_score, confusion_matrix, f1_score, recall_score

from terrain.errors import (ConfigError, ShapeError, duplicated, refuse_missing,
                            refuse_mixed_types)


def _check_windows(owner: str, **columns) -> None:
    """Refuse per-window sequences of other lengths, or of no window (ShapeError), and a
    missing label or run (NonFiniteInputError: NaN was scored as a class ``'nan'``, None
    failed in NumPy's sort, a missing prediction was left out of the run vote)."""
    lengths = {name: len(values) for name, values in columns.items()}
    names = " and ".join(", ".join(lengths).rsplit(", ", 1))
    if len(set(lengths.values())) > 1:
        raise ShapeError(f"{owner}: {names} must hold one entry per window, got lengths "
                         f"{tuple(lengths.values())}")
    if not next(iter(lengths.values())):
        raise ShapeError(f"{owner}: {names} hold no window")
    for name, values in columns.items():
        refuse_missing(owner, name, values, "run(s)" if name == "groups" else "label(s)",
                       "every window needs its class and its run")
        refuse_mixed_types(owner, name, values)   # (NumPy's bare "'<' not supported")


def _label_array(values) -> np.ndarray:
    """Labels as an array of their own type: an object array (pandas' object column of
    integers) holds one type family once :func:`_check_windows` passed it, and is read as
    that type's array (scikit-learn's metrics refused an object array of integers as targets
    of type 'unknown', a bare ValueError)."""
    a = np.asarray(values)
    return np.asarray(a.tolist()) if a.dtype == object else a


def _check_classes(owner: str, classes: Sequence[str]) -> list:
    """``classes`` as a list; ConfigError where one is repeated (it would be scored twice)."""
    classes = list(classes)
    repeated = duplicated(classes)
    if repeated:
        raise ConfigError(f"{owner}: classes must be distinct, {repeated} given more than "
                          "once (a repeated class is scored twice)")
    return classes


def window_metrics(y_true: Sequence[str], y_pred: Sequence[str],
                   classes: Sequence[str]) -> dict[str, float]:
    """Window-level metrics.

    Parameters
    ----------
    y_true : sequence of str
        ``(n_windows,)`` true terrain label of each window.
    y_pred : sequence of str
        ``(n_windows,)`` predicted label of each window.
    classes : sequence of str
        All class labels of the task, in the order of the ``recall_`` keys (see Returns
        for which each metric counts); a label of ``y_true`` or ``y_pred`` outside them
        counts as a class too, after them (a predicted class the list lacks scores F1 0
        in ``macro_f1``, as in scikit-learn's macro average).

    Returns
    -------
    dict
        ``accuracy``, ``balanced_accuracy`` (mean recall over the classes present in
        ``y_true``), ``macro_f1`` (over the classes present in ``y_true`` or ``y_pred``, as
        scikit-learn's ``f1_score(average="macro")``: a class predicted in a fold whose
        truth lacks it counts with F1 = 0) and ``recall_<CLASS>`` for each class present in
        ``y_true``.

    Raises
    ------
    ShapeError
        ``y_true`` and ``y_pred`` of other lengths, or empty (scikit-learn's bare
        "inconsistent numbers of samples" / "Found empty input array").
    ConfigError
        A class repeated in ``classes`` (it was scored twice in the means).
    NonFiniteInputError
        A missing label (NaN or None) in ``y_true`` or ``y_pred``.
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``y_true`` or
        ``y_pred`` (:func:`terrain.errors.refuse_mixed_types`).
    """
    _check_windows("window_metrics", y_true=y_true, y_pred=y_pred)
    classes = _check_classes("window_metrics", classes)
    y_true, y_pred = _label_array(y_true), _label_array(y_pred)
    # a label outside classes counts too, after them: a predicted class the list lacks
    # was left out of macro-F1 (a held-out truth's classes, the model knowing one more)
    known = set(classes)
    labels = list(classes) + [c for c in np.unique(np.concatenate([y_true, y_pred])).tolist()
                              if c not in known]
    present = [c for c in labels if (y_true == c).any()]
    scored = [c for c in labels if (y_true == c).any() or (y_pred == c).any()]
    recalls = recall_score(y_true, y_pred, labels=present, average=None, zero_division=0)
    out = {
        "accuracy": float(accuracy_score(y_true, y_pred)),
        # scikit-learn's balanced accuracy is this mean of the recalls of the classes in
        # y_true; balanced_accuracy_score also warns when a fold's predictions hold a class
        # its truth lacks (a Vulpi fold), which is not a fault of anything
        "balanced_accuracy": float(np.mean(recalls)),
        "macro_f1": float(f1_score(y_true, y_pred, labels=scored, average="macro",
                                   zero_division=0)),
    }
    out.update({f"recall_{c}": float(r) for c, r in zip(present, recalls)})
    return out


def majority_vote(y_pred: Sequence[str], groups: Sequence[str]) -> pd.Series:
    """Most frequent predicted label per group (ties: alphabetical first).

    Parameters
    ----------
    y_pred : sequence of str
        ``(n_windows,)`` predicted label of each window.
    groups : sequence of str
        ``(n_windows,)`` group (run, or split unit) of each window.

    Returns
    -------
    pandas.Series
        Group -> voted label, indexed by the sorted group ids.

    Raises
    ------
    ShapeError
        ``y_pred`` and ``groups`` of other lengths (was pandas's bare "All arrays must be of
        the same length"), or empty.
    NonFiniteInputError
        A group or a prediction is missing (NaN or None: pandas' ``groupby`` would leave its
        windows out of the vote, and out of :func:`run_majority_accuracy`'s count).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``y_pred`` or
        ``groups`` (:func:`terrain.errors.refuse_mixed_types`).
    """
    _check_windows("majority_vote", y_pred=y_pred, groups=groups)
    frame = pd.DataFrame({"g": np.asarray(groups), "p": np.asarray(y_pred)})
    counts = frame.groupby(["g", "p"]).size().reset_index(name="n")
    counts = counts.sort_values(["g", "n", "p"], ascending=[True, False, True])
    return counts.drop_duplicates("g").set_index("g")["p"]


def run_majority_accuracy(y_true: Sequence[str], y_pred: Sequence[str],
                          groups: Sequence[str]) -> float:
    """Fraction of runs (groups) whose majority-vote prediction is their true label.

    Parameters
    ----------
    y_true : sequence of str
        ``(n_windows,)`` true terrain label of each window.
    y_pred : sequence of str
        ``(n_windows,)`` predicted label of each window.
    groups : sequence of str
        ``(n_windows,)`` run (or split unit) of each window; a group's true label is that of
        its first window.

    Returns
    -------
    float
        Correctly voted groups / groups, in [0, 1] (see :func:`majority_vote`).

    Raises
    ------
    ShapeError
        The three sequences not of one length (was pandas's bare "Length of values does
        not match length of index"), or empty (was NaN).
    NonFiniteInputError
        A missing label or group (:func:`majority_vote`).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``y_true``,
        ``y_pred`` or ``groups`` (:func:`terrain.errors.refuse_mixed_types`).
    """
    _check_windows("run_majority_accuracy", y_true=y_true, y_pred=y_pred, groups=groups)
    truth = pd.Series(np.asarray(y_true), index=np.asarray(groups))
    truth = truth[~truth.index.duplicated()]
    vote = majority_vote(y_pred, groups)
    return float((vote == truth.loc[vote.index]).mean())


def confusion(y_true: Sequence[str], y_pred: Sequence[str],
              classes: Sequence[str]) -> pd.DataFrame:
    """Confusion matrix as a frame (rows: true class, columns: predicted class, counts).

    Parameters
    ----------
    y_true : sequence of str
        ``(n_windows,)`` true terrain label of each window.
    y_pred : sequence of str
        ``(n_windows,)`` predicted label of each window.
    classes : sequence of str
        Row and column labels, in this order (labels outside it are not counted).

    Returns
    -------
    pandas.DataFrame
        ``(n_classes, n_classes)`` window counts, index ``true``, columns ``predicted``.

    Raises
    ------
    ShapeError
        ``y_true`` and ``y_pred`` of other lengths, or empty (scikit-learn's bare
        "inconsistent numbers of samples" / "Found empty input array").
    ConfigError
        ``classes`` empty, or a class repeated in it (a row of the matrix got no count).
    NonFiniteInputError
        A missing label (NaN or None) in ``y_true`` or ``y_pred``.
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``y_true`` or
        ``y_pred`` (:func:`terrain.errors.refuse_mixed_types`).
    """
    _check_windows("confusion", y_true=y_true, y_pred=y_pred)
    classes = _check_classes("confusion", classes)
    if not classes:
        raise ConfigError("confusion: classes is empty: the matrix would have no row")
    cm = confusion_matrix(_label_array(y_true), _label_array(y_pred), labels=classes)
    return pd.DataFrame(cm, index=pd.Index(classes, name="true"),
                        columns=pd.Index(classes, name="predicted"))


def plot_confusion(cm: pd.DataFrame, title: str = ""):
    """Row-normalised confusion matrix as a matplotlib figure (counts in the cells).

    Parameters
    ----------
    cm : pandas.DataFrame
        ``(n_classes, n_classes)`` counts as returned by :func:`confusion` (rows true class).
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure     # not pyplot's: no figure left open per call

    counts = cm.to_numpy()
    norm = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1)
    fig = Figure(figsize=(1.2 * len(cm) + 2, 1.1 * len(cm) + 1.5))
    ax = fig.subplots()
    ax.imshow(norm, cmap="Blues", vmin=0, vmax=1)
    ax.set_xticks(range(len(cm.columns)), cm.columns, rotation=45, ha="right")
    ax.set_yticks(range(len(cm.index)), cm.index)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    for i in range(counts.shape[0]):
        for j in range(counts.shape[1]):
            ax.text(j, i, f"{counts[i, j]}\n{norm[i, j]:.2f}", ha="center", va="center",
                    fontsize=7, color="white" if norm[i, j] > 0.5 else "black")
    ax.set_title(title)
    fig.tight_layout()
    return fig
