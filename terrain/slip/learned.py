"""Learned slip model: per-side longitudinal slip and the turning factor chi from window features.

A scikit-learn estimator (:class:`SlipRegressor`) over the feature table of
:func:`features.slip_features.slip_features`, trained on simulated runs with truth
(``terrain slip-fit``). Gradient-boosted trees (:class:`sklearn.ensemble.HistGradientBoostingRegressor`),
one per output: ``slip_1`` (left), ``slip_2`` (right) and ``v_by`` (lateral body velocity,
m/s: the sideways sliding that makes the slip angle ``atan(v_by / v_bx)`` of seed 003) on every
window, ``chi`` on the windows where the robot turns (its target is undefined elsewhere; the
prediction there is still defined and only matters when the robot turns).

:meth:`SlipRegressor.predict` walks the fitted trees with the compiled adaptor
:mod:`terrain.slip.tree_predict` (bit-identical to scikit-learn's ``predict``, which pays
~10-20 us of Python per tree and call); :meth:`SlipRegressor.predict_reference` is
scikit-learn's own path, kept as the reference.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.ensemble import HistGradientBoostingRegressor

from terrain.errors import ShapeError
from terrain.slip.tree_predict import pack_trees, predict_packed

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
    """

    def __init__(self, max_iter: int = 300, learning_rate: float = 0.1,
                 max_leaf_nodes: int = 31, min_samples_leaf: int = 20,
                 random_state: int = 0) -> None:
        self.max_iter = max_iter
        self.learning_rate = learning_rate
        self.max_leaf_nodes = max_leaf_nodes
        self.min_samples_leaf = min_samples_leaf
        self.random_state = random_state

    def _tree(self) -> HistGradientBoostingRegressor:
        return HistGradientBoostingRegressor(
            max_iter=self.max_iter, learning_rate=self.learning_rate,
            max_leaf_nodes=self.max_leaf_nodes, min_samples_leaf=self.min_samples_leaf,
            early_stopping=False, random_state=self.random_state)

    def fit(self, X, y) -> "SlipRegressor":
        """Fit the four outputs.

        Parameters
        ----------
        X : array-like, shape (n_windows, n_features)
            Window features.
        y : array-like, shape (n_windows, 4)
            ``slip_1, slip_2`` (dimensionless), ``chi`` (NaN where undefined), ``v_by``
            (m/s).

        Returns
        -------
        SlipRegressor

        Raises
        ------
        ShapeError
            ``y`` is not ``(n_windows, 4)``.
        """
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        if y.ndim != 2 or y.shape != (len(X), len(SLIP_OUTPUTS)):
            raise ShapeError(f"y must have shape ({len(X)}, {len(SLIP_OUTPUTS)}), got {y.shape}")
        self.n_features_in_ = X.shape[1]
        self.slip_models_ = [self._tree().fit(X, y[:, i]) for i in range(2)]
        turning = np.isfinite(y[:, 2])
        self.chi_default_ = float(np.nanmedian(y[:, 2])) if turning.any() else 1.0
        self.chi_model_ = (self._tree().fit(X[turning], y[turning, 2])
                           if turning.sum() >= 2 * self.min_samples_leaf else None)
        self.lateral_model_ = self._tree().fit(X, y[:, 3])
        self.packed_trees_ = pack_trees(self._estimators(), self.n_features_in_)
        return self

    def _estimators(self) -> list[HistGradientBoostingRegressor]:
        return [*self.slip_models_,
                *([self.chi_model_] if self.chi_model_ is not None else []),
                self.lateral_model_]

    def _check_X(self, X) -> np.ndarray:
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != self.n_features_in_:
            raise ShapeError(f"X must have shape (n_windows, {self.n_features_in_}), "
                             f"got {X.shape}")
        return X

    def predict(self, X) -> np.ndarray:
        """Predict ``slip_1, slip_2, chi, v_by``.

        Parameters
        ----------
        X : array-like, shape (n_windows, n_features)
            Window features (same columns as in :meth:`fit`).

        Returns
        -------
        ndarray, shape (n_windows, 4)
            ``slip_1, slip_2`` (dimensionless), ``chi``, ``v_by`` (m/s); identical to
            :meth:`predict_reference`.

        Raises
        ------
        ShapeError
            ``X`` has another number of columns than in :meth:`fit`.
        """
        X = self._check_X(X)
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
            Window features (same columns as in :meth:`fit`).

        Returns
        -------
        ndarray, shape (n_windows, 4)
            ``slip_1, slip_2, chi, v_by``.

        Raises
        ------
        ShapeError
            ``X`` has another number of columns than in :meth:`fit`.
        """
        X = self._check_X(X)
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
        """
        err = np.abs(self.predict(X)[:, :2] - np.asarray(y, dtype=float)[:, :2])
        return -float(np.median(err))
