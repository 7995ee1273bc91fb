"""Learned slip model: per-side longitudinal slip and the turning factor chi from window features.

A scikit-learn estimator (:class:`SlipRegressor`) over the feature table of
:func:`features.slip_features.slip_features`, trained on simulated runs with truth
(``terrain slip-fit``). Gradient-boosted trees
(:class:`sklearn.ensemble.HistGradientBoostingRegressor`),
one per output: ``slip_1`` (left), ``slip_2`` (right) and ``v_by`` (lateral body velocity,
m/s: the sideways sliding that makes the slip angle ``atan(v_by / v_bx)`` of seed 003) on every
window, ``chi`` on the windows where the robot turns (its target is undefined elsewhere; the
prediction there is still defined and only matters when the robot turns).

:meth:`SlipRegressor.predict` walks the fitted trees with the compiled adaptor
:mod:`terrain.tree_predict` (bit-identical to scikit-learn's ``predict``, which pays
~10-20 us of Python per tree and call); :meth:`SlipRegressor.predict_reference` is
scikit-learn's own path, kept as the reference.
"""

from __future__ import annotations

import hashlib
import warnings

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.ensemble import HistGradientBoostingRegressor
from sklearn.utils.validation import check_is_fitted

from terrain.errors import (ConfigError, DataWarning, MissingColumnError, NonFiniteInputError,
                            ShapeError, config_integer, config_positive, duplicated, listed,
                            refuse_infinite, refuse_missing, refuse_mixed_types)
from terrain.tree_predict import pack_trees, predict_packed

#: Median of the chi-square distribution with one degree of freedom (scipy.stats.chi2(1).median()).
CHI2_1_MEDIAN = 0.454936423119572
#: What a refusal of infinite features adds (:func:`~terrain.errors.refuse_infinite`).
_INF_WHY = "a feature is finite, or NaN where it is missing"
#: Output columns of :meth:`SlipRegressor.predict`.
SLIP_OUTPUTS = ("slip_1", "slip_2", "chi", "v_by")


class SlipRegressor(RegressorMixin, BaseEstimator):
    """Per-side slip, chi and lateral velocity regressor (scikit-learn estimator).

    Parameters
    ----------
    max_iter : int
        Boosting iterations per output.
    learning_rate : float
        Shrinkage.
    max_leaf_nodes : int
        Leaves per tree.
    min_samples_leaf : int
        Minimum windows per leaf.
    random_state : int
        Seed (the trees are deterministic without early stopping; kept for clones).
    calibration_folds : int
        Grouped folds of the out-of-fold slip residuals the standard deviation is calibrated
        on (:meth:`fit` with ``groups``; an integer >= 0, fewer than 2 disables the
        calibration).
    std_floor : float
        Documented floor of :meth:`predict_std`, dimensionless slip, finite and > 0 (0.0005:
        below it the out-of-fold residuals of the training windows are at the level of the
        simulator's window-mean truth on firm ground, where slip is ~1e-4, and a smaller std
        would let one window dominate the filter).

    Attributes
    ----------
    n_features_in_ : int
        Number of feature columns seen in :meth:`fit`.
    feature_names_in_ : ndarray of str, shape (n_features_in_,)
        The column names of ``X`` in :meth:`fit`, when it was a DataFrame with text column
        names (scikit-learn's convention); a DataFrame given to :meth:`predict` must then have
        exactly these columns in this order. Absent after a fit on a bare array, and on models
        stored before the names were kept (they predict as before, unchecked).
    """

    def __init__(self, max_iter: int = 300, learning_rate: float = 0.1,
                 max_leaf_nodes: int = 31, min_samples_leaf: int = 20,
                 random_state: int = 0, calibration_folds: int = 3,
                 std_floor: float = 0.0005) -> None:
        self.max_iter = max_iter
        self.learning_rate = learning_rate
        self.max_leaf_nodes = max_leaf_nodes
        self.min_samples_leaf = min_samples_leaf
        self.random_state = random_state
        self.calibration_folds = calibration_folds
        self.std_floor = std_floor

    def _tree(self) -> HistGradientBoostingRegressor:
        return HistGradientBoostingRegressor(
            max_iter=self.max_iter, learning_rate=self.learning_rate,
            max_leaf_nodes=self.max_leaf_nodes, min_samples_leaf=self.min_samples_leaf,
            early_stopping=False, random_state=self.random_state)

    def fit(self, X, y, groups=None) -> "SlipRegressor":
        """Fit the four outputs and, with ``groups``, the calibrated slip standard deviation.

        Calibration (inside the training data only): out-of-fold slip predictions over
        ``calibration_folds`` folds grouped by ``groups`` (runs: overlapping windows of a run
        never sit on both sides) give residuals ``r``; a small gradient-boosted model of
        ``log(r^2 + floor^2)`` on the window features (both sides stacked) gives the shape of
        the variance over the feature space, and a scale ``c`` sets its level so that the median
        normalised squared residual ``r^2 / (c exp(z))`` is the chi-square(1) median on
        residuals the variance model did not see (cross-fitted over the same folds): 68 % of
        the bulk within 1 std; the tails stay heavier than Gaussian (``calibration_``).
        :meth:`predict_std` returns ``max(std_floor, sqrt(c exp(z(x))))``.

        Parameters
        ----------
        X : array-like, shape (n_windows, n_features)
            Window features; a DataFrame with text column names sets ``feature_names_in_``
            (a bare array, or other column names, leaves it unset).
        y : array-like, shape (n_windows, 4)
            ``slip_1, slip_2`` (dimensionless), ``chi`` (NaN where undefined), ``v_by``
            (m/s).
        groups : array-like, shape (n_windows,), optional
            Run of each window (grouped calibration folds); None: no calibration
            (:meth:`predict_std` then returns NaN). The ids only group the windows: the
            folds are dealt from the runs' data (:func:`calibration_folds`), so renaming
            runs changes neither the predictions nor the std.

        Returns
        -------
        SlipRegressor
            ``self``; a fit that raises leaves a fitted model as it was before the call.

        Raises
        ------
        ConfigError
            ``std_floor`` not a finite number > 0 (it keeps the log-variance target finite
            where a residual is 0), or ``calibration_folds`` not an integer >= 0.
        ShapeError
            ``X`` is not 2-D, ``y`` is not ``(n_windows, 4)``, or ``groups`` has another
            length than ``X``.
        NonFiniteInputError
            A feature of ``X`` is infinite (the message names its column and row; NaN is a
            missing feature, which the trees learn where to send), a ``slip_1``, ``slip_2``
            or ``v_by`` target is NaN or infinite, a ``chi`` target is infinite, or a run of
            ``groups`` is missing (NaN or None).

        Warns
        -----
        DataWarning
            Fewer than ``2 min_samples_leaf`` windows with a chi target (turning): chi is
            not learned, :meth:`predict` gives their median (1 without any) on every window;
            or too few runs in ``groups`` for the calibration folds (no std).
        MixedTypesError
            Values of types that do not sort together (text or booleans beside numbers) in
            ``groups`` (:func:`terrain.errors.refuse_mixed_types`).
        """
        # a fit that fails (scikit-learn refusing an empty table, a calibration fold) leaves
        # the model as it was: it was half refitted, n_features_in_ new and its trees old
        before = dict(vars(self))
        try:
            return self._fit(X, y, groups)
        except BaseException:
            vars(self).clear()
            vars(self).update(before)
            raise

    def _fit(self, X, y, groups) -> "SlipRegressor":
        """The body of :meth:`fit` (which restores the model when this raises)."""
        # (NaN made the variance target NaN, 0 made it -inf at a zero residual: scikit-learn's
        # bare errors about a y that was fine; 2.5 folds failed after the four fits)
        config_positive("SlipRegressor", std_floor=self.std_floor)
        config_integer("SlipRegressor.calibration_folds", self.calibration_folds, 0)
        names = _text_columns(X)
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        if X.ndim != 2:
            raise ShapeError(f"X must have shape (n_windows, n_features), got {X.shape}")
        # (scikit-learn's trees took inf as the largest value, without a word)
        refuse_infinite("SlipRegressor.fit", X, names, _INF_WHY)
        if y.ndim != 2 or y.shape != (len(X), len(SLIP_OUTPUTS)):
            raise ShapeError(f"y must have shape ({len(X)}, {len(SLIP_OUTPUTS)}), got {y.shape}")
        for i in (0, 1, 3):         # chi alone may be NaN (undefined when not turning)
            bad = ~np.isfinite(y[:, i])
            if bad.any():
                raise NonFiniteInputError(
                    f"{int(bad.sum())} of {len(y)} training windows have a non-finite "
                    f"{SLIP_OUTPUTS[i]} target (first rows {np.flatnonzero(bad)[:3].tolist()}):"
                    " only chi may be NaN")
        bad = np.isinf(y[:, 2])     # NaN says "not turning"; inf was silently taken for it
        if bad.any():
            raise NonFiniteInputError(
                f"{int(bad.sum())} of {len(y)} training windows have an infinite chi target "
                f"(first rows {np.flatnonzero(bad)[:3].tolist()}): chi is finite, or NaN where "
                "the robot does not turn")
        if groups is not None:  # checked whether or not it is used, before any fit
            groups = np.asarray(groups)
            if len(groups) != len(X):
                raise ShapeError(f"groups has {len(groups)} entries for {len(X)} windows")
            # (None: a bare TypeError, NaN: scikit-learn's error, both after the four fits)
            refuse_missing("SlipRegressor.fit", "groups", groups, "run(s)",
                           "the calibration folds group every window by its run")
            refuse_mixed_types("SlipRegressor.fit", "groups", groups)   # (NumPy's sort)
        self.n_features_in_ = X.shape[1]
        if names is not None:
            self.feature_names_in_ = names
        elif hasattr(self, "feature_names_in_"):     # refitted on a bare array
            del self.feature_names_in_
        self.slip_models_ = [self._tree().fit(X, y[:, i]) for i in range(2)]
        turning = np.isfinite(y[:, 2])
        self.chi_default_ = float(np.nanmedian(y[:, 2])) if turning.any() else 1.0
        self.chi_model_ = (self._tree().fit(X[turning], y[turning, 2])
                           if turning.sum() >= 2 * self.min_samples_leaf else None)
        if self.chi_model_ is None:     # a constant chi: said, not left to be found out
            warnings.warn(f"slip model chi not learned: {int(turning.sum())} turning training "
                          f"window(s), fewer than {2 * self.min_samples_leaf} (2 "
                          f"min_samples_leaf); predict gives the constant chi "
                          f"{self.chi_default_:.4g} ("
                          f"{'their median' if turning.any() else 'no turning window'})",
                          DataWarning, stacklevel=3)
        self.lateral_model_ = self._tree().fit(X, y[:, 3])
        self.packed_trees_ = pack_trees(self._estimators(), self.n_features_in_)
        self.std_model_, self.std_scale_, self.calibration_ = None, float("nan"), {}
        vars(self).pop("packed_std_", None)     # a previous fit's std trees (refit)
        if groups is not None and self.calibration_folds >= 2:
            n_groups = len(np.unique(groups))
            if n_groups >= self.calibration_folds:
                self._calibrate(X, y, groups)
            else:   # the model has no std: said, not left to a NaN downstream
                warnings.warn(f"slip model std not calibrated: {n_groups} training run(s) "
                              f"for {self.calibration_folds} calibration folds; predict_std "
                              f"gives NaN (train on more runs)", DataWarning, stacklevel=3)
        return self

    def _std_tree(self) -> HistGradientBoostingRegressor:
        return HistGradientBoostingRegressor(max_iter=100, learning_rate=0.1, max_leaf_nodes=15,
                                             min_samples_leaf=50, early_stopping=False,
                                             random_state=self.random_state)

    def _calibrate(self, X: np.ndarray, targets: np.ndarray, groups: np.ndarray) -> None:
        folds = calibration_folds(X, targets, groups, self.calibration_folds)
        y = targets[:, :2]
        oof = np.full_like(y, np.nan)
        for tr, te in folds:
            for i in range(2):
                oof[te, i] = self._tree().fit(X[tr], y[tr, i]).predict(X[te])
        r = y - oof
        z = np.log(r ** 2 + self.std_floor ** 2)
        z_cf = np.full_like(z, np.nan)            # variance shape on unseen residuals
        for tr, te in folds:
            m = self._std_tree().fit(np.vstack([X[tr], X[tr]]), z[tr].T.ravel())
            z_cf[te] = m.predict(X[te])[:, None]
        # the bulk, not the tails: the median normalised squared residual is set to the
        # chi-square(1) median (68 % of Gaussian residuals within 1 std); a mean would let
        # the heavy tails of transients (random commands, wheels spinning on slopes) inflate
        # the std of every window
        self.std_scale_ = float(np.median(r ** 2 / np.exp(z_cf)) / CHI2_1_MEDIAN)
        self.std_model_ = self._std_tree().fit(np.vstack([X, X]), z.T.ravel())
        self.packed_std_ = pack_trees([self.std_model_], self.n_features_in_)
        sd = np.maximum(self.std_floor, np.sqrt(self.std_scale_ * np.exp(z_cf)))
        u = np.abs(r) / sd
        self.calibration_ = {"n_windows": float(len(X)), "scale": self.std_scale_,
                             "mean_normalised_sq": float(np.mean(u ** 2)),
                             "median_normalised_sq": float(np.median(u ** 2)),
                             "coverage_1std": float(np.mean(u <= 1.0)),
                             "coverage_2std": float(np.mean(u <= 2.0)),
                             "median_std": float(np.median(sd)),
                             "median_abs_residual": float(np.median(np.abs(r)))}

    def predict_std(self, X, moment: str = "median") -> np.ndarray:
        """Calibrated standard deviation of the predicted ``slip_1, slip_2`` (see :meth:`fit`).

        Parameters
        ----------
        X : array-like, shape (n_windows, n_features)
            Window features (same columns as in :meth:`fit`); a DataFrame must have the
            columns ``feature_names_in_`` in that order when the model has them, a bare
            array is taken as in that order.
        moment : {"median", "variance"}
            ``median``: the bulk calibration of :meth:`fit` (68 % of typical windows within
            1 std). ``variance``: scaled by ``sqrt(mean normalised squared residual)`` of the
            same out-of-fold calibration (``calibration_["mean_normalised_sq"]``), so that
            the mean squared error over the training residuals equals the variance, as a
            Kalman filter's measurement variance must (the heavy tails included); never
            below the median std (the factor is floored at 1: a mean below the median's
            would make the filter's measurement more certain than the bulk of the errors).

        Returns
        -------
        ndarray, shape (n_windows, 2)
            Dimensionless slip std per side (the same for both sides), >= ``std_floor``; NaN
            when the model was fitted without ``groups`` (no calibration).

        Raises
        ------
        sklearn.exceptions.NotFittedError, ShapeError, MissingColumnError, NonFiniteInputError
            As :meth:`predict`.
        ConfigError
            Unknown ``moment``.
        """
        if moment not in ("median", "variance"):
            raise ConfigError(f"unknown moment {moment!r}; valid: median, variance")
        X = self._check_X(X, "predict_std")
        if getattr(self, "std_model_", None) is None:
            return np.full((len(X), 2), np.nan)
        z = predict_packed(self.packed_std_, X)[:, 0]
        sd = np.maximum(self.std_floor, np.sqrt(self.std_scale_ * np.exp(z)))
        if moment == "variance":
            sd = sd * np.sqrt(max(1.0, self.calibration_.get("mean_normalised_sq", 1.0)))
        return np.repeat(sd[:, None], 2, axis=1)

    def _estimators(self) -> list[HistGradientBoostingRegressor]:
        return [*self.slip_models_,
                *([self.chi_model_] if self.chi_model_ is not None else []),
                self.lateral_model_]

    def _check_X(self, X, method: str) -> np.ndarray:
        check_is_fitted(self, "slip_models_")       # not a bare AttributeError before fit
        fitted = getattr(self, "feature_names_in_", None)  # absent: stored before the names
        wrong = (feature_names_mismatch([str(c) for c in X.columns], list(fitted))
                 if fitted is not None and isinstance(X, pd.DataFrame) else None)
        if wrong is not None:       # a named table of any width: name its columns
            raise wrong
        names = list(X.columns) if isinstance(X, pd.DataFrame) else fitted
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != self.n_features_in_:
            raise ShapeError(f"X must have shape (n_windows, {self.n_features_in_}), "
                             f"got {X.shape}")
        # (the compiled trees and scikit-learn's predict took inf as the largest value)
        refuse_infinite(f"SlipRegressor.{method}", X, names, _INF_WHY)
        return X

    def predict(self, X) -> np.ndarray:
        """Predict ``slip_1, slip_2, chi, v_by``.

        Parameters
        ----------
        X : array-like, shape (n_windows, n_features)
            Window features (same columns as in :meth:`fit`); a DataFrame must have the
            columns ``feature_names_in_`` in that order when the model has them, a bare
            array is taken as in that order.

        Returns
        -------
        ndarray, shape (n_windows, 4)
            ``slip_1, slip_2`` (dimensionless), ``chi``, ``v_by`` (m/s); identical to
            :meth:`predict_reference`.

        Raises
        ------
        sklearn.exceptions.NotFittedError
            The model has not been fitted.
        ShapeError
            ``X`` has another number of columns than in :meth:`fit` and is not a DataFrame
            checked by name (below).
        MissingColumnError
            The model has ``feature_names_in_`` and ``X`` is a DataFrame whose columns are
            not those in that order, whatever its width (the message names the missing,
            extra or misplaced columns: :func:`feature_names_mismatch`).
        NonFiniteInputError
            A feature of ``X`` is infinite, naming its column (as ``feature_names_in_`` when
            the model has them, else its position) and row; NaN is a missing feature, as in
            :meth:`fit`.
        """
        X = self._check_X(X, "predict")
        packed = getattr(self, "packed_trees_", None)
        if packed is None:              # a model fitted before the adaptor existed
            packed = pack_trees(self._estimators(), self.n_features_in_)
        raw = predict_packed(packed, X)
        if self.chi_model_ is None:
            raw = np.insert(raw, 2, self.chi_default_, axis=1)
        return raw

    def predict_reference(self, X) -> np.ndarray:
        """:meth:`predict` through scikit-learn's own ``predict`` of each tree ensemble.

        The reference for the compiled path (identical output, ~100x slower per call).

        Parameters
        ----------
        X : array-like, shape (n_windows, n_features)
            Window features (same columns as in :meth:`fit`); a DataFrame must have the
            columns ``feature_names_in_`` in that order when the model has them, a bare
            array is taken as in that order.

        Returns
        -------
        ndarray, shape (n_windows, 4)
            ``slip_1, slip_2, chi, v_by``.

        Raises
        ------
        sklearn.exceptions.NotFittedError, ShapeError, MissingColumnError, NonFiniteInputError
            As :meth:`predict`.
        """
        X = self._check_X(X, "predict_reference")
        chi = (self.chi_model_.predict(X) if self.chi_model_ is not None
               else np.full(len(X), self.chi_default_))
        return np.column_stack([m.predict(X) for m in self.slip_models_]
                               + [chi, self.lateral_model_.predict(X)])

    def score(self, X, y, sample_weight=None) -> float:
        """Negative median absolute slip error over both sides (higher is better).

        Parameters
        ----------
        X : array-like, shape (n_windows, n_features)
            Window features.
        y : array-like, shape (n_windows, 4)
            True outputs.
        sample_weight : None
            Unused (scikit-learn signature).

        Returns
        -------
        float

        Raises
        ------
        sklearn.exceptions.NotFittedError, ShapeError, MissingColumnError, NonFiniteInputError
            As :meth:`predict`; ShapeError also for a ``y`` without one row per window of
            ``X`` and at least the two slip columns.
        """
        pred = self.predict(X)
        y = np.asarray(y, dtype=float)
        if y.ndim != 2 or len(y) != len(pred) or y.shape[1] < 2:
            # (a 1-D y was a bare IndexError, another row count a broadcasting ValueError)
            raise ShapeError(f"y must have shape ({len(pred)}, >= 2) (slip_1, slip_2 of each "
                             f"window first), got {y.shape}")
        err = np.abs(pred[:, :2] - y[:, :2])
        return -float(np.median(err))


def calibration_folds(X: np.ndarray, y: np.ndarray, groups: np.ndarray,
                      n_folds: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Run-grouped folds of the std calibration, dealt from the runs' data, not their ids.

    As scikit-learn's ``GroupKFold`` (no run on both sides; the runs with the most windows
    are dealt first, each to the fold with the fewest windows so far, the lowest-numbered
    among equals), but runs of equal window counts come in the order of their median
    ``|slip|`` (both sides), then of a digest of their sorted targets (all four), then of one
    of their sorted features, never of their ids: the folds, hence the calibrated std, do not
    depend on how the runs are named (only runs equal in all of that, copies of one another,
    keep the order of their ids). Runs with identical targets (one trajectory under other
    sensor noise: the seeds of a scripted scenario, whose truth the seed does not change) go
    to the fold holding the fewest of them (then the lightest), so that while there are
    folds enough each is calibrated by a model that saw the trajectory, as on a held-out
    seed. ``GroupKFold`` did the same by the
    accident of ids that sort such runs next to each other (``.../orchard/0``,
    ``.../orchard/1``); dealt in another order, a scripted trajectory whose runs all sat in
    one fold had out-of-fold residuals of an unseen trajectory and a std to match (20 times
    the error of a held-out seed on ASPHALT). Consecutive runs of that order go to different
    folds, so every fold spans the slip levels of the training set. Invariant to the row
    order, the feature column order and a swap of the sides.

    Parameters
    ----------
    X : ndarray, shape (n_windows, n_features)
        Window features.
    y : ndarray, shape (n_windows, n_targets)
        Targets of :meth:`SlipRegressor.fit`, ``slip_1, slip_2`` (dimensionless) first
        (NaN allowed after them: ``chi``).
    groups : ndarray, shape (n_windows,)
        Run of each window (no NaN or None: :meth:`SlipRegressor.fit` refuses them).
    n_folds : int
        Folds, >= 2 and at most the number of runs.

    Returns
    -------
    list of (ndarray, ndarray)
        ``(train, test)`` window indices per fold, each ascending (as scikit-learn's
        ``split``).

    Raises
    ------
    ConfigError
        ``n_folds`` below 2 or above the number of runs.
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``groups``
        (:func:`terrain.errors.refuse_mixed_types`).
    """
    refuse_mixed_types("calibration_folds", "groups", groups)   # (NumPy's bare TypeError)
    runs, run_of = np.unique(groups, return_inverse=True)
    run_of = run_of.ravel()
    if not 2 <= n_folds <= len(runs):
        raise ConfigError(f"{n_folds} calibration folds need 2 to {len(runs)} (the runs)")
    X, y = np.asarray(X, dtype=float), np.asarray(y, dtype=float)
    keys = []
    for k in range(len(runs)):
        rows = run_of == k
        keys.append((-int(rows.sum()), float(np.median(np.abs(y[rows, :2]))),
                     hashlib.sha256(np.sort(y[rows], axis=None).tobytes()).hexdigest(),
                     hashlib.sha256(np.sort(X[rows], axis=None).tobytes()).hexdigest()))
    fold_of_run = np.zeros(len(runs), dtype=int)
    load = np.zeros(n_folds, dtype=int)
    holds: list[dict] = [{} for _ in range(n_folds)]    # runs per target digest, per fold
    for k in sorted(range(len(runs)), key=keys.__getitem__):
        fold = min(range(n_folds), key=lambda f: (holds[f].get(keys[k][2], 0), load[f], f))
        fold_of_run[k] = fold
        load[fold] -= keys[k][0]
        holds[fold][keys[k][2]] = holds[fold].get(keys[k][2], 0) + 1
    fold_of = fold_of_run[run_of]
    return [(np.flatnonzero(fold_of != f), np.flatnonzero(fold_of == f))
            for f in range(n_folds)]


def _text_columns(X) -> np.ndarray | None:
    """The column names of a DataFrame whose names are all text, else None (scikit-learn's
    rule for ``feature_names_in_``)."""
    if isinstance(X, pd.DataFrame) and all(isinstance(c, str) for c in X.columns):
        return np.asarray(list(X.columns), dtype=object)
    return None


def feature_names_mismatch(columns: list[str], fitted: list[str]) -> MissingColumnError | None:
    """What is wrong with a feature table's columns against those a model was fitted on.

    A tree ensemble reads its inputs by position: the same columns in another order predict
    without an error and wrongly (two swapped currents swap the sides' slips).

    Parameters
    ----------
    columns : list of str, length n_columns
        Column names of the table to predict on.
    fitted : list of str, length n_features
        Column names of the table the model was fitted on (``feature_names_in_``).

    Returns
    -------
    MissingColumnError or None
        None when ``columns`` is ``fitted``; otherwise the error to raise, naming the first
        few fitted columns missing, columns the model does not know, columns given twice, or
        (the same columns in another order) the misplaced ones; its ``column`` is the first
        of them.
    """
    if columns == fitted:
        return None
    where = f"the {len(fitted)} feature columns the slip model was fitted on"
    given, known = set(columns), set(fitted)
    missing = [c for c in fitted if c not in given]
    extra = [c for c in columns if c not in known]
    if missing or extra:
        return MissingColumnError(
            f"X's columns differ from {where}: "
            + "; ".join(f"{word} {listed(items)}" for word, items in
                        (("missing", missing), ("extra", extra)) if items),
            column=(missing or extra)[0])
    twice = duplicated(columns)
    if twice:
        return MissingColumnError(f"X has the column(s) {listed(twice)} more than once (of "
                                  f"{where})", column=twice[0])
    moved = [(i, c, f) for i, (c, f) in enumerate(zip(columns, fitted)) if c != f]
    return MissingColumnError(
        f"X has {where} in another order: "
        + ", ".join(f"column {i} is {c!r} where the model has {f!r}" for i, c, f in moved[:3])
        + (f" and {len(moved) - 3} more misplaced" if len(moved) > 3 else "")
        + " (reorder as feature_names_in_)", column=moved[0][1])
