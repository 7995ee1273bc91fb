"""Compiled prediction for fitted gradient-boosted trees: a thin adaptor, not a second model.

scikit-learn's :class:`~sklearn.ensemble.HistGradientBoostingRegressor` predicts one tree at
a time from Python (``_predict_iterations``: one call into Cython per tree), which costs
~10-20 us per tree whatever the number of rows: 4 outputs x 300 trees make a single-window
call last tens of milliseconds. :func:`pack_trees` copies the node arrays of the *fitted*
estimators (``_predictors[i][0].nodes``, scikit-learn's ``PREDICTOR_RECORD_DTYPE``) and their
``_baseline_prediction`` into flat arrays, and :func:`predict_packed` walks them in one
compiled loop (numba) with scikit-learn's own rules (``_predictor.pyx``,
``_predict_one_from_raw_data``): a NaN feature goes to ``missing_go_to_left``'s side, otherwise
``x <= num_threshold`` goes left; the output is the baseline plus the leaf values added in
iteration order, so it is bit-identical to ``estimator.predict`` (squared-error loss, identity
link). Nothing is fitted or approximated here; the equality is tested
(``tests/slip/test_tree_predict.py``).
"""

from __future__ import annotations

from typing import Sequence

import numba
import numpy as np

from terrain.errors import ConfigError, ShapeError

#: Keys of a packed forest (:func:`pack_trees`).
PACKED_KEYS = ("feature", "threshold", "missing_left", "left", "right", "is_leaf", "value",
               "tree_start", "model_start", "baseline", "n_features")


def pack_trees(estimators: Sequence, n_features: int) -> dict[str, np.ndarray]:
    """Flat node arrays of fitted single-output gradient-boosted regressors.

    Parameters
    ----------
    estimators : sequence of sklearn.ensemble.HistGradientBoostingRegressor
        Fitted estimators (squared-error loss, numeric features only), one per output.
    n_features : int
        Number of input features the estimators were fitted on.

    Returns
    -------
    dict of str to ndarray
        :data:`PACKED_KEYS`: per node (all trees concatenated) ``feature`` (int64),
        ``threshold`` (float64, same units as the feature), ``missing_left`` (bool),
        ``left``/``right`` (int64, global node index), ``is_leaf`` (bool), ``value``
        (float64, the leaf's contribution); ``tree_start`` (int64, n_trees + 1) the first node
        of each tree; ``model_start`` (int64, n_models + 1) the first tree of each estimator;
        ``baseline`` (float64, n_models) each estimator's ``_baseline_prediction``;
        ``n_features`` (int64, shape (1,)).

    Raises
    ------
    ConfigError
        No estimator, or an estimator is unfitted, has a loss other than squared error,
        more than one tree per iteration, or a categorical split.
    """
    nodes, tree_start, model_start, baseline = [], [0], [0], []
    n_nodes = n_trees = 0
    for est in estimators:
        if not hasattr(est, "_predictors"):
            raise ConfigError(f"{type(est).__name__} is not fitted")
        if getattr(est, "loss", None) != "squared_error" or est.n_trees_per_iteration_ != 1:
            raise ConfigError("pack_trees supports single-output squared-error regressors "
                              f"only (loss {getattr(est, 'loss', None)!r})")
        for (pred,) in est._predictors:
            nd = pred.nodes
            if nd["is_categorical"].any():
                raise ConfigError("pack_trees does not support categorical splits")
            nodes.append((nd, n_nodes))
            n_nodes += len(nd)
            n_trees += 1
            tree_start.append(n_nodes)
        model_start.append(n_trees)
        baseline.append(float(np.asarray(est._baseline_prediction).ravel()[0]))
    if not nodes:
        raise ConfigError("pack_trees needs at least one fitted estimator")
    offset = np.concatenate([np.full(len(nd), off, np.int64) for nd, off in nodes])
    nd_all = np.concatenate([nd for nd, _ in nodes])
    return {
        "feature": nd_all["feature_idx"].astype(np.int64),
        "threshold": nd_all["num_threshold"].astype(np.float64),
        "missing_left": nd_all["missing_go_to_left"].astype(bool),
        "left": nd_all["left"].astype(np.int64) + offset,
        "right": nd_all["right"].astype(np.int64) + offset,
        "is_leaf": nd_all["is_leaf"].astype(bool),
        "value": nd_all["value"].astype(np.float64),
        "tree_start": np.asarray(tree_start, np.int64),
        "model_start": np.asarray(model_start, np.int64),
        "baseline": np.asarray(baseline, np.float64),
        "n_features": np.asarray([n_features], np.int64),
    }


def predict_packed(packed: dict[str, np.ndarray], X) -> np.ndarray:
    """Predictions of the packed estimators, identical to each estimator's ``predict``.

    Parameters
    ----------
    packed : dict of str to ndarray
        :func:`pack_trees` output.
    X : array-like, shape (n_rows, n_features)
        Numeric features (float64 after conversion; NaN = missing).

    Returns
    -------
    ndarray, shape (n_rows, n_models)
        Column ``m`` equals ``estimators[m].predict(X)``.

    Raises
    ------
    ShapeError
        ``X`` is not 2-D or has another number of columns than the estimators were fitted on.
    """
    X = np.ascontiguousarray(X, dtype=np.float64)
    n_features = int(packed["n_features"][0])
    if X.ndim != 2 or X.shape[1] != n_features:
        raise ShapeError(f"X must have shape (n_rows, {n_features}), got {X.shape}")
    out = np.empty((X.shape[0], len(packed["baseline"])), dtype=np.float64)
    _walk(packed["feature"], packed["threshold"], packed["missing_left"], packed["left"],
          packed["right"], packed["is_leaf"], packed["value"], packed["tree_start"],
          packed["model_start"], packed["baseline"], X, out)
    return out


@numba.njit(cache=True, nogil=True)
def _walk(feature, threshold, missing_left, left, right, is_leaf, value, tree_start,
          model_start, baseline, X, out):   # pragma: no cover - compiled
    # Trees outer, rows inner (one tree's nodes stay in cache over all rows), as scikit-learn;
    # each row's sum is still baseline + tree 0 + tree 1 + ... in iteration order.
    n_rows = X.shape[0]
    for m in range(baseline.shape[0]):
        for r in range(n_rows):
            out[r, m] = baseline[m]
        for t in range(model_start[m], model_start[m + 1]):
            root = tree_start[t]
            for r in range(n_rows):
                i = root
                while not is_leaf[i]:
                    x = X[r, feature[i]]
                    if np.isnan(x):
                        i = left[i] if missing_left[i] else right[i]
                    elif x <= threshold[i]:
                        i = left[i]
                    else:
                        i = right[i]
                out[r, m] += value[i]
