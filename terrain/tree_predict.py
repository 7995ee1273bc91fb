"""Compiled prediction for fitted tree ensembles: thin adaptors, not second models.

scikit-learn predicts one tree at a time from Python (one call into Cython per tree), which
costs ~10-40 us per tree whatever the number of rows: hundreds of trees make a single-window
call last tens of milliseconds. The adaptors here copy the node arrays of the *fitted*
estimators into flat arrays once and walk them in one compiled loop (numba) with
scikit-learn's own rules, so they reproduce its output exactly. Nothing is fitted or
approximated here; the equality is tested (``tests/slip/test_tree_predict.py``,
``tests/models/test_forest_predict.py``).

* Gradient-boosted regressors (:func:`pack_trees`, :func:`predict_packed`, used by the
  learned slip model): scikit-learn's :class:`~sklearn.ensemble.HistGradientBoostingRegressor`
  nodes (``_predictors[i][0].nodes``, ``PREDICTOR_RECORD_DTYPE``) and
  ``_baseline_prediction``, walked with the rules of ``_predictor.pyx``
  (``_predict_one_from_raw_data``): a NaN feature goes to ``missing_go_to_left``'s side,
  otherwise ``x <= num_threshold`` goes left; the output is the baseline plus the leaf values
  added in iteration order, bit-identical to ``estimator.predict`` (squared-error loss,
  identity link).
* Random-forest / extra-trees classifiers (:func:`pack_forest`, :func:`forest_proba`, used
  by the wheel-only streaming model): each tree's ``tree_`` arrays (``children_left``,
  ``children_right``, ``feature``, ``threshold``, ``missing_go_to_left``, ``value``), walked
  with the rules of ``_tree.pyx`` (``Tree._apply_dense``): the input is cast to float32 as
  scikit-learn does, a NaN goes to ``missing_go_to_left``'s side, otherwise
  ``x <= threshold`` goes left. A classifier tree's leaf ``value`` is already the
  (class-weighted) fraction of each class among the leaf's training samples, which is what
  ``DecisionTreeClassifier.predict_proba`` returns; ``class_weight`` changes those fractions
  at fit time, not the rule. ``ForestClassifier.predict_proba`` adds the trees' leaf
  fractions in tree order and divides by the number of trees, and so does
  :func:`forest_proba`.
"""

from __future__ import annotations

from typing import Sequence

import numba
import numpy as np

from terrain.errors import ConfigError, ShapeError, refuse_infinite

#: Keys of packed gradient-boosted trees (:func:`pack_trees`).
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
        No estimator, or an estimator is unfitted, was fitted on another number of
        features than ``n_features``, has a loss other than squared error, more than one
        tree per iteration, or a categorical split.
    """
    nodes, tree_start, model_start, baseline = [], [0], [0], []
    n_nodes = n_trees = 0
    for est in estimators:
        if not hasattr(est, "_predictors"):
            raise ConfigError(f"{type(est).__name__} is not fitted")
        if getattr(est, "loss", None) != "squared_error" or est.n_trees_per_iteration_ != 1:
            raise ConfigError("pack_trees supports single-output squared-error regressors "
                              f"only (loss {getattr(est, 'loss', None)!r})")
        if est.n_features_in_ != n_features:   # (the compiled walk reads X unchecked)
            raise ConfigError(f"pack_trees: {type(est).__name__} was fitted on "
                              f"{est.n_features_in_} features, not n_features={n_features}")
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


#: Keys of a packed classifier forest (:func:`pack_forest`).
FOREST_KEYS = ("feature", "threshold", "missing_left", "left", "right", "value",
               "tree_start", "n_features")


def pack_forest(forest) -> dict[str, np.ndarray]:
    """Flat node arrays of a fitted single-output random-forest / extra-trees classifier.

    Parameters
    ----------
    forest : sklearn.ensemble.ExtraTreesClassifier or sklearn.ensemble.RandomForestClassifier
        Fitted forest of ``DecisionTreeClassifier`` (or ``ExtraTreeClassifier``) with one
        output; any ``class_weight``.

    Returns
    -------
    dict of str to ndarray
        :data:`FOREST_KEYS`: per node (all trees concatenated) ``feature`` (int64),
        ``threshold`` (float64, same units as the feature), ``missing_left`` (bool),
        ``left``/``right`` (int64, global node index, -1 at a leaf), ``value`` (float64,
        ``(n_nodes, n_classes)``, the leaf's class fractions, columns in ``forest.classes_``
        order); ``tree_start`` (int64, n_trees + 1) the first node of each tree;
        ``n_features`` (int64, shape (1,)).

    Raises
    ------
    ConfigError
        The forest is not fitted, has no tree, more than one output, or a tree with
        another number of classes than the forest.
    """
    trees = getattr(forest, "estimators_", None)
    if not trees:
        raise ConfigError(f"{type(forest).__name__} is not fitted")
    if getattr(forest, "n_outputs_", 1) != 1 or not hasattr(forest, "classes_"):
        raise ConfigError("pack_forest supports single-output classifier forests only")
    n_classes = len(forest.classes_)
    parts, tree_start, n_nodes = [], [0], 0
    for est in trees:
        t = est.tree_
        if t.n_outputs != 1 or t.value.shape[2] != n_classes:
            raise ConfigError("pack_forest: a tree's classes differ from the forest's")
        left, right = t.children_left.astype(np.int64), t.children_right.astype(np.int64)
        leaf = left < 0
        missing = getattr(t, "missing_go_to_left", np.zeros(t.node_count, np.uint8))
        parts.append((t.feature.astype(np.int64), t.threshold.astype(np.float64),
                      np.asarray(missing).astype(bool),
                      np.where(leaf, -1, left + n_nodes), np.where(leaf, -1, right + n_nodes),
                      t.value[:, 0, :].astype(np.float64)))
        n_nodes += t.node_count
        tree_start.append(n_nodes)
    cols = [np.concatenate([p[k] for p in parts]) for k in range(6)]
    return {"feature": cols[0], "threshold": cols[1], "missing_left": cols[2],
            "left": cols[3], "right": cols[4], "value": np.ascontiguousarray(cols[5]),
            "tree_start": np.asarray(tree_start, np.int64),
            "n_features": np.asarray([forest.n_features_in_], np.int64)}


def forest_proba(packed: dict[str, np.ndarray], X) -> np.ndarray:
    """Class probabilities of a packed forest, equal to the forest's ``predict_proba``.

    Parameters
    ----------
    packed : dict of str to ndarray
        :func:`pack_forest` output.
    X : array-like, shape (n_rows, n_features)
        Numeric features (cast to float32 as scikit-learn does; NaN = missing).

    Returns
    -------
    ndarray, shape (n_rows, n_classes)
        Mean over the trees of the leaf class fractions, columns in ``classes_`` order.

    Raises
    ------
    ShapeError
        ``X`` is not 2-D or has another number of columns than the forest was fitted on.
    NonFiniteInputError
        ``X`` holds an infinite value (or one beyond float32), which scikit-learn refuses;
        the message names the count, the first one's column (0-based position) and row
        (:func:`~terrain.errors.refuse_infinite`).
    """
    X = np.asarray(X)
    n_features = int(packed["n_features"][0])
    if X.ndim != 2 or X.shape[1] != n_features:
        raise ShapeError(f"X must have shape (n_rows, {n_features}), got {X.shape}")
    X32 = np.ascontiguousarray(X, dtype=np.float32)
    # (named no column nor row); one beyond float32 is infinite once cast, as in scikit-learn
    refuse_infinite("forest_proba", X32, why="infinite, or too large for float32")
    out = np.zeros((X32.shape[0], packed["value"].shape[1]), dtype=np.float64)
    _walk_forest(packed["feature"], packed["threshold"], packed["missing_left"],
                 packed["left"], packed["right"], packed["value"], packed["tree_start"],
                 X32, out)
    return out


@numba.njit(cache=True, nogil=True)
def _walk_forest(feature, threshold, missing_left, left, right, value, tree_start, X,
                 out):   # pragma: no cover - compiled
    # Trees outer, rows inner, leaf fractions added in tree order from zero, then / n_trees:
    # the same float64 operations in the same order as ForestClassifier.predict_proba.
    n_rows, n_classes = X.shape[0], value.shape[1]
    n_trees = tree_start.shape[0] - 1
    for t in range(n_trees):
        root = tree_start[t]
        for r in range(n_rows):
            i = root
            while left[i] >= 0:
                x = X[r, feature[i]]
                if np.isnan(x):
                    i = left[i] if missing_left[i] else right[i]
                elif np.float64(x) <= threshold[i]:
                    i = left[i]
                else:
                    i = right[i]
            for c in range(n_classes):
                out[r, c] += value[i, c]
    for r in range(n_rows):
        for c in range(n_classes):
            out[r, c] /= n_trees
