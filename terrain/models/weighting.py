"""Training weights that give every run of a terrain the same share, and a wrapper that
fits any classifier with them.

The windows of one run are not independent samples of its terrain: one surface patch, one
speed profile and one recording day. Cut at a fixed hop, a long run gives many more
windows than a short one (of the BorealTC runs with an IMU, ASPHALT/01 holds 56 % of the
ASPHALT recordings and ICE/00 38 % of the ICE ones; with the wheels only, ICE/01 holds about a
quarter of all windows), so it dominates what the classifier learns of its class. An unseen run, or
a held-out stream that takes a stretch of every run once (docs/streaming.md), weighs the
runs about equally instead. :func:`within_class_run_weights` gives every run of a class
the same total weight and keeps the class totals as they are, so a classifier's own class
balancing (``class_weight="balanced"``, the CNNs' weighted loss) stays in charge of the
classes. :class:`RunBalancedClassifier` fits a classifier with these weights.
"""

from __future__ import annotations

import inspect

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted

from terrain.errors import ConfigError, ShapeError, refuse_missing, refuse_mixed_types
from terrain.models.cv import fit_with_groups


def run_shares(labels, groups) -> np.ndarray:
    """Each window's share of its class when every run of the class counts the same.

    ``1 / (n_runs(class) n(run))``: the windows of one class sum to 1, those of one run
    to ``1 / n_runs(class)``.

    Parameters
    ----------
    labels, groups : array-like
        ``(n_windows,)`` class and run of each window.

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)`` shares (> 0).

    Raises
    ------
    ShapeError
        ``labels`` and ``groups`` are not 1-D arrays of one length.
    NonFiniteInputError
        A label or run is missing (NaN, None, NaT or pandas' NA:
        :func:`terrain.errors.refuse_missing`); the message names the argument and the
        first window.
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``labels`` or
        ``groups`` (:func:`terrain.errors.refuse_mixed_types`).
    """
    labels, groups = np.asarray(labels), np.asarray(groups)
    if labels.ndim != 1 or labels.shape != groups.shape:
        raise ShapeError(f"labels {labels.shape} and groups {groups.shape} must be 1-D "
                         "arrays of one length")
    # the shared rule (pandas.isna): a NaT run, pandas' NA or a float32 NaN in an object
    # array passed a check of its own, equalled no run and kept np.empty's unset value
    for name, values in (("labels", labels), ("groups", groups)):
        refuse_missing("run_shares", name, values, "value(s)",
                       "every window needs its class and its run")
        refuse_mixed_types("run_shares", name, values)   # (NumPy's bare "'<' not supported")
    share = np.empty(labels.size)
    for c in np.unique(labels):
        in_class = labels == c
        runs = np.unique(groups[in_class])
        for r in runs:
            rows = in_class & (groups == r)
            share[rows] = 1.0 / (runs.size * rows.sum())
    return share


def within_class_run_weights(labels, groups) -> np.ndarray:
    """Window weights under which every run of a class has the same total weight.

    ``w = n(class) / (n_runs(class) n(run))`` (:func:`run_shares` times the class's window
    count): inside every class the weights have mean 1 and each run sums to
    ``n(class) / n_runs(class)``, so every class keeps its window count as its total weight.

    Parameters
    ----------
    labels, groups : array-like
        ``(n_windows,)`` class and run of each window.

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)`` weights (> 0, mean 1 within each class).

    Raises
    ------
    ShapeError
        ``labels`` and ``groups`` are not 1-D arrays of one length.
    NonFiniteInputError
        A label or run is missing (NaN or None, :func:`run_shares`).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``labels`` or
        ``groups`` (:func:`run_shares`) (:func:`terrain.errors.refuse_mixed_types`).
    """
    share = run_shares(labels, groups)
    _, inverse, per_class = np.unique(np.asarray(labels), return_inverse=True,
                                      return_counts=True)
    return share * per_class[inverse]


def run_balanced(estimator) -> "RunBalancedClassifier":
    """``estimator`` fitted with :func:`within_class_run_weights`, the weights routed to it.

    Parameters
    ----------
    estimator : classifier
        Unfitted; a :class:`sklearn.pipeline.Pipeline` gets the weights in its last step
        (``<step>__sample_weight``), anything else as ``sample_weight``.

    Returns
    -------
    RunBalancedClassifier
    """
    param = (f"{estimator.steps[-1][0]}__sample_weight" if isinstance(estimator, Pipeline)
             else "sample_weight")
    return RunBalancedClassifier(estimator, weight_param=param)


def _check_weight_param(estimator, param: str) -> None:
    """ConfigError where ``estimator``'s ``fit`` cannot take the weights as ``param``: a
    Pipeline's ``<step>__...`` must name one of its steps, anything else's ``fit`` must name
    ``param`` or take ``**kwargs`` (scikit-learn's bare TypeError "unexpected keyword
    argument", or the Pipeline's ValueError, came from inside the fit)."""
    if isinstance(estimator, Pipeline):
        step, sep, _ = str(param).partition("__")
        names = [name for name, _ in estimator.steps]
        if not (sep and step in names):
            raise ConfigError(f"weight_param {param!r} names no step of the Pipeline: give "
                              f"'<step>__sample_weight' with a step among {names}")
        return
    fit_params = inspect.signature(estimator.fit).parameters
    if param not in fit_params and not any(p.kind is p.VAR_KEYWORD
                                           for p in fit_params.values()):
        raise ConfigError(f"weight_param {param!r} is no parameter of "
                          f"{type(estimator).__name__}.fit "
                          f"({[n for n in fit_params if n not in ('X', 'y')]})")


class RunBalancedClassifier(ClassifierMixin, BaseEstimator):
    """A classifier fitted with :func:`within_class_run_weights` of its training windows.

    Parameters
    ----------
    estimator : classifier
        Unfitted scikit-learn classifier whose ``fit`` takes the weights as the fit
        parameter ``weight_param``.
    weight_param : str
        Name of that fit parameter: ``sample_weight``, or ``<step>__sample_weight`` for a
        :class:`sklearn.pipeline.Pipeline` (e.g. ``svc__sample_weight``).

    Attributes
    ----------
    estimator_ : classifier
        The fitted copy of ``estimator``.
    classes_ : numpy.ndarray
        Its labels, in the order of ``predict_proba``.
    n_features_in_ : int
        Number of input features: the fitted estimator's own ``n_features_in_``, else
        ``X.shape[1]`` (channels for a raw ``(n_windows, n_channels, n_samples)`` input);
        absent where neither exists (the last fit's, never an earlier fit's).
    """

    def __init__(self, estimator, weight_param: str = "sample_weight") -> None:
        self.estimator = estimator
        self.weight_param = weight_param

    def fit(self, X, y, groups=None):
        """Fit a copy of ``estimator`` with every run of a class weighing the same.

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` the estimator's input.
        y : array-like
            ``(n_windows,)`` labels.
        groups : array-like
            ``(n_windows,)`` run of every window; also handed on to an estimator whose
            ``fit`` takes ``groups``.

        Returns
        -------
        self

        Raises
        ------
        ConfigError
            ``groups`` is missing, or ``weight_param`` names no step of a Pipeline (or, for
            another estimator, no parameter of its ``fit``).
        ShapeError
            ``y`` and ``groups`` differ in length.
        NonFiniteInputError
            A label or run is missing (NaN or None, :func:`run_shares`).
        MixedTypesError
            Values of types that do not sort together (text or booleans beside numbers) in ``y`` or
            ``groups`` (:func:`run_shares`) (:func:`terrain.errors.refuse_mixed_types`).
        """
        if groups is None:
            raise ConfigError("run-balanced weights need the run of every window (groups)")
        _check_weight_param(self.estimator, self.weight_param)
        self.estimator_ = fit_with_groups(clone(self.estimator), X, y, groups, **{
            self.weight_param: within_class_run_weights(y, groups)})
        self.classes_ = self.estimator_.classes_
        n_features = getattr(self.estimator_, "n_features_in_", None)
        if n_features is None:
            # X.shape of an array or sparse matrix; np.shape would call an array-like's
            # __array_function__ (scikit-learn's _NotAnArray refuses it)
            shape = X.shape if hasattr(X, "shape") else np.asarray(X).shape
            n_features = shape[1] if len(shape) >= 2 else None
        if n_features is not None:
            self.n_features_in_ = n_features
        else:   # (a refit on such input kept the width of the previous fit's input)
            vars(self).pop("n_features_in_", None)
        return self

    def predict_proba(self, X) -> np.ndarray:
        """Class probabilities of the fitted estimator.

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` the estimator's input.

        Returns
        -------
        numpy.ndarray
            ``(n_windows, n_classes)``, columns in the order of ``classes_``.
        """
        check_is_fitted(self, "estimator_")
        return self.estimator_.predict_proba(X)

    def predict(self, X) -> np.ndarray:
        """Labels predicted by the fitted estimator.

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` the estimator's input.

        Returns
        -------
        numpy.ndarray
            ``(n_windows,)`` labels from ``classes_``.
        """
        check_is_fitted(self, "estimator_")
        return self.estimator_.predict(X)
