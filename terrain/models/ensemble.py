"""Soft-voting ensemble of terrain classifiers with weights chosen on held-out training runs.

The ensemble averages the members' class probabilities with non-negative weights summing
to 1. With ``weights=None`` and the run of every training window given to ``fit``, the
weights are chosen on a grid of the simplex (step ``weight_step``) by the log loss of the
members' probabilities on whole runs held out of the training data (the first
``StratifiedGroupKFold(inner_splits)`` split that leaves every class a training run):
nothing outside the training fold is seen. A vector replaces the best one before it in
:func:`simplex_grid`'s order only when its log loss is lower by more than 1e-12: a tie goes to
the first.
The members are then refitted on every training window. Without ``groups``, or with a single
class (every weight vector gives it probability 1), the weights are equal.
"""

from __future__ import annotations

import itertools
from numbers import Real
from typing import Sequence

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.metrics import log_loss
from sklearn.utils import _safe_indexing, get_tags
from sklearn.utils.validation import check_is_fitted

from terrain.errors import ConfigError, duplicated, holds_booleans, listed, refuse_mixed_types
from terrain.models.cv import (class_keeping_split, fit_with_groups, member_probabilities,
                               restored_on_failure)


def normalised_weights(weights, n_members: int) -> np.ndarray:
    """Fixed member weights scaled to sum 1, one per member.

    Parameters
    ----------
    weights : sequence of float
        One non-negative weight per member, not all 0.
    n_members : int
        Number of members.

    Returns
    -------
    numpy.ndarray
        ``(n_members,)`` weights summing to 1.

    Raises
    ------
    ConfigError
        Not one weight per member (a member would be dropped silently), a boolean weight
        (a member mask read as 1 / 0), a negative or non-finite weight, or all weights 0.
    """
    if holds_booleans(weights) or (isinstance(weights, (list, tuple)) and any(
            isinstance(v, (bool, np.bool_)) for v in weights)):   # [True, 0.5] is float
        raise ConfigError(f"member weights must be numbers, not booleans, got {weights!r:.80}")
    w = np.asarray(weights, dtype=float).ravel()
    if w.size != n_members:
        raise ConfigError(f"{w.size} weight(s) for {n_members} members: give one per member")
    if not (np.isfinite(w).all() and (w >= 0).all() and w.sum() > 0):
        raise ConfigError(f"member weights must be finite, >= 0 and not all 0, got "
                          f"{w.tolist()}")
    return w / w.sum()


def capped_at_one(proba: np.ndarray) -> np.ndarray:
    """Weighted sums of member probabilities with rounding above 1 taken back to 1.

    Weights summing to 1 and members all certain of a window (probability 1) sum to
    1 + 2e-16 for some weights (nine of 1/9 each), which scikit-learn's ``log_loss`` and
    ``brier_score_loss`` refuse ("y_prob contains values greater than 1"). Only such
    rounding excess is changed (in place); every other probability is kept bit for bit.

    Parameters
    ----------
    proba : numpy.ndarray
        ``(n_windows, n_classes)`` weighted sums of member probabilities.

    Returns
    -------
    numpy.ndarray
        ``proba``, with every value above 1 set to 1.
    """
    return np.minimum(proba, 1.0, out=proba)


def simplex_grid(n_members: int, step: float) -> np.ndarray:
    """Every weight vector on the simplex with coordinates in multiples of ``step``.

    Parameters
    ----------
    n_members : int
        Number of weights.
    step : float
        Grid step, in (0, 1]; ``1 / step`` must be an integer.

    Returns
    -------
    numpy.ndarray
        ``(n_points, n_members)`` non-negative rows summing to 1.

    Raises
    ------
    ConfigError
        ``step`` not a number (a boolean included), outside (0, 1] or ``1 / step`` not an
        integer.
    """
    n = (round(1.0 / step) if isinstance(step, Real) and not isinstance(step, bool)
         and 0 < step <= 1 else 0)
    if n < 1 or not np.isclose(n * step, 1.0):
        raise ConfigError(f"weight_step must be in (0, 1] with 1 / weight_step an integer "
                          f"(0.5, 0.25, 0.1, ...), got {step!r}")
    rows = [c for c in itertools.product(range(n + 1), repeat=n_members) if sum(c) == n]
    return np.asarray(rows, dtype=float) / n


def aligned_proba(estimator, X, classes: np.ndarray) -> np.ndarray:
    """``predict_proba`` of a fitted member with columns aligned to ``classes``.

    Parameters
    ----------
    estimator : classifier
        Fitted, with ``classes_`` and ``predict_proba``.
    X : array-like
        Its input (raw windows ``(n_windows, n_channels, n_samples)``).
    classes : numpy.ndarray
        ``(n_classes,)`` target column order; classes the member never saw get 0.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_classes)`` float64, each row of the member's probabilities divided
        by its sum (:func:`~terrain.models.cv.member_probabilities`).
    """
    proba = member_probabilities(estimator.predict_proba(X))
    out = np.zeros((proba.shape[0], len(classes)))
    out[:, class_columns(estimator.classes_, classes)] = proba
    return out


def class_columns(member_classes: np.ndarray, classes: np.ndarray) -> np.ndarray:
    """Column of each of a member's classes in the ensemble's class order.

    Parameters
    ----------
    member_classes : numpy.ndarray
        ``(n_member_classes,)`` a member's ``classes_``.
    classes : numpy.ndarray
        ``(n_classes,)`` target column order, containing every member class.

    Returns
    -------
    numpy.ndarray
        ``(n_member_classes,)`` integer indices into ``classes``.
    """
    index = {c: i for i, c in enumerate(classes)}
    return np.array([index[c] for c in member_classes], dtype=np.intp)


class SoftVotingEnsemble(ClassifierMixin, BaseEstimator):
    """Weighted average of member class probabilities.

    Parameters
    ----------
    estimators : list of (str, estimator)
        Named members, each with ``predict_proba`` on the same input.
    weights : sequence of float or None
        Fixed weights (normalised to sum 1); ``None``: chosen in ``fit`` (see module; equal
        without ``groups`` or with a single class).
    weight_step : float
        Step of the simplex grid searched for the weights.
    inner_splits : int
        ``1 / inner_splits`` of the training runs are held out to choose the weights.
    random_state : int
        Seed of the inner run split.

    Attributes
    ----------
    classes_ : numpy.ndarray
        Labels, in the order of ``predict_proba``.
    estimators_ : list of estimator
        Members fitted on every training window.
    weights_ : numpy.ndarray
        ``(n_members,)`` weights used.
    weight_scores_ : dict
        Held-out log loss of every weight vector tried (empty where none was: fixed
        weights, no ``groups`` or a single class).
    validation_groups_ : numpy.ndarray
        Runs held out to choose the weights (the first inner split that leaves every
        class a training run); empty when the weights are not chosen.
    columns_ : list of numpy.ndarray
        Column in ``classes_`` of each fitted member's classes (:func:`class_columns`).
    n_features_in_ : int
        ``X.shape[1]`` in ``fit`` (channels of raw windows; features of a table); the
        members check their own input at prediction. Absent after a fit on input with no
        second axis.
    """

    def __init__(self, estimators: Sequence[tuple[str, object]], weights=None,
                 weight_step: float = 0.25, inner_splits: int = 4,
                 random_state: int = 0) -> None:
        self.estimators = estimators
        self.weights = weights
        self.weight_step = weight_step
        self.inner_splits = inner_splits
        self.random_state = random_state

    def __sklearn_tags__(self):
        """scikit-learn's tags, with the input tags of the members: sparse input or NaN
        is accepted only when every member accepts it (as scikit-learn's own voting
        ensembles do); the members' fits raise their own errors otherwise."""
        tags = super().__sklearn_tags__()
        members = [est for _, est in self.estimators]
        tags.input_tags.sparse = all(get_tags(est).input_tags.sparse for est in members)
        tags.input_tags.allow_nan = all(get_tags(est).input_tags.allow_nan for est in members)
        return tags

    def fit(self, X, y, groups=None):
        """Choose the weights on held-out training runs, then fit every member.

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` members' input (raw windows).
        y : array-like
            ``(n_windows,)`` labels.
        groups : array-like or None
            ``(n_windows,)`` run of every window (needed to choose the weights).

        Returns
        -------
        self

        Raises
        ------
        ConfigError
            No member (``estimators`` empty), or two members of one name; fixed ``weights``
            not one per member,
            boolean, negative, non-finite or all 0 (:func:`normalised_weights`); weights to choose
            with fewer runs (``groups``) than ``inner_splits``, or every class with fewer
            windows than ``inner_splits``, or where every inner split
            holds out every run of a class (:func:`~terrain.models.cv.class_keeping_split`),
            or a ``weight_step`` :func:`simplex_grid` refuses.
        ValueError
            ``y`` is None. A refused fit (here or a member's) leaves the ensemble as it was
            (unfitted, or its previous fit whole:
            :func:`~terrain.models.cv.restored_on_failure`).
        MixedTypesError
            Values of types that do not sort together (text or booleans beside numbers) in ``y``, or
            ``groups`` when the weights are chosen (:func:`~terrain.models.cv.class_keeping_split`)
            (:func:`terrain.errors.refuse_mixed_types`).
        """
        with restored_on_failure(self):
            return self._fit(X, y, groups)

    def _fit(self, X, y, groups):
        """:meth:`fit` itself (which puts the previous fit back where this raises)."""
        if y is None:      # scikit-learn's own "y should be a 1d array, got ... shape ()"
            raise ValueError(f"{type(self).__name__} requires y to be passed, but the target "
                             "y is None: give the (n_windows,) labels of the training windows")
        if len(self.estimators) == 0:
            raise ConfigError(f"{type(self).__name__} needs at least one member "
                              "(estimators: a list of (name, estimator)), got none")
        twice = duplicated(name for name, _ in self.estimators)
        if twice:   # (the logged weight_<name> of the two collapsed into one)
            raise ConfigError(f"{type(self).__name__}: member name(s) {listed(twice)} given "
                              "twice; name each member once")
        y = np.asarray(y)
        refuse_mixed_types(type(self).__name__, "y", y)   # (NumPy's bare "'<' not supported")
        # X.shape of an array or sparse matrix; np.shape would call an array-like's
        # __array_function__ (scikit-learn's _NotAnArray refuses it)
        shape = X.shape if hasattr(X, "shape") else np.asarray(X).shape
        if len(shape) >= 2:
            self.n_features_in_ = shape[1]
        else:   # (a refit on such input kept the width of the previous fit's input)
            vars(self).pop("n_features_in_", None)
        self.classes_ = np.unique(y)
        n = len(self.estimators)
        self.weight_scores_ = {}
        self.validation_groups_ = np.asarray([] if groups is None else groups)[:0]
        if self.weights is not None:
            self.weights_ = normalised_weights(self.weights, n)
        elif groups is None or len(self.classes_) < 2:
            # one class: every vector gives it probability 1, there is nothing to choose
            # (log_loss refused it with a bare "needs to contain at least two labels")
            self.weights_ = np.full(n, 1.0 / n)
        else:
            groups = np.asarray(groups)
            grid = simplex_grid(n, self.weight_step)
            tr, va = class_keeping_split(y, groups, self.inner_splits, self.random_state,
                                         "choosing the ensemble weights", "inner_splits",
                                         "fixed weights")
            self.validation_groups_ = np.unique(groups[va])
            X_tr, X_va = _safe_indexing(X, tr), _safe_indexing(X, va)   # a list too
            probas = [aligned_proba(fit_with_groups(clone(est), X_tr, y[tr], groups[tr]), X_va,
                                    self.classes_) for _, est in self.estimators]
            best, best_w = np.inf, None
            for w in grid:
                p = sum(wi * pi for wi, pi in zip(w, probas))
                p = np.clip(p, 1e-12, 1.0)
                score = log_loss(y[va], p / p.sum(axis=1, keepdims=True), labels=self.classes_)
                self.weight_scores_[tuple(np.round(w, 4))] = float(score)
                if score < best - 1e-12:
                    best, best_w = score, w
            self.weights_ = best_w
        self.estimators_ = [fit_with_groups(clone(est), X, y, groups) for _, est in self.estimators]
        self.columns_ = [class_columns(est.classes_, self.classes_) for est in self.estimators_]
        return self

    def predict_proba(self, X) -> np.ndarray:
        """Weighted mean of the members' probabilities.

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` members' input.

        Returns
        -------
        numpy.ndarray
            ``(n_windows, n_classes)``, columns in the order of ``classes_``; each member's
            rows are divided by their sum in float64 first
            (:func:`~terrain.models.cv.member_probabilities`: a float32 member such as
            MiniRocket sums to 1 within ~1e-7 only), so the rows sum to 1 within float64
            rounding.
        """
        check_is_fitted(self, "estimators_")
        columns = getattr(self, "columns_", None)
        if columns is None:    # fitted before columns_ existed (unpickled)
            columns = [class_columns(est.classes_, self.classes_) for est in self.estimators_]
        out = None
        for w, est, cols in zip(self.weights_, self.estimators_, columns):
            proba = member_probabilities(est.predict_proba(X))  # a float32 member's rows
            if out is None:
                out = np.zeros((proba.shape[0], len(self.classes_)))
            out[:, cols] += w * proba
        return capped_at_one(out)

    def predict(self, X) -> np.ndarray:
        """Label of the highest mean probability.

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` members' input.

        Returns
        -------
        numpy.ndarray
            ``(n_windows,)`` labels.
        """
        proba = self.predict_proba(X)       # before classes_: unfitted is NotFittedError
        return self.classes_[proba.argmax(axis=1)]
