"""SVM terrain classifier: ``StandardScaler`` + ``SVC`` with class balancing.

The thesis classifies terrain with an SVM on window features
(``001_59da564c4b2d6a48.txt`` ch. 8.1); BorealTC and Vulpi use an SVM on four statistical
moments as their classical baseline. Hyperparameters are tuned by :func:`make_search`, a grid
search whose inner folds are grouped by run and see training runs only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from sklearn.calibration import CalibratedClassifierCV
from sklearn.model_selection import GridSearchCV, StratifiedGroupKFold
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC
from sklearn.utils.multiclass import type_of_target

from features.transformers import WindowFeatures
from terrain.errors import (ConfigError, config_flags, config_integer, config_positive,
                            refuse_mixed_types)
from terrain.models.compiled import CompiledPipeline
from terrain.models.cv import require_runs


@dataclass(frozen=True)
class SVMConfig:
    """SVM hyperparameters and search grid.

    Parameters
    ----------
    C : float
        Regularisation (larger = less).
    gamma : float or str
        RBF kernel width (``"scale"`` = 1 / (n_features var(X))).
    probability : bool
        Wrap the SVC in ``CalibratedClassifierCV(method="sigmoid", ensemble=False)`` (Platt
        scaling on 5-fold out-of-fold decision values) so the model gives class
        probabilities, as needed for serving. Its ``predict`` is then the argmax of those
        probabilities, not the SVC's own vote, so the calibration shapes evaluated figures
        too: the ``svm`` cells of ``terrain compare``, every ensemble's vote and the decision
        history (``terrain cv --model svm`` without ``--window-ekf`` cross-validates the
        uncalibrated SVC). The calibration folds are ``StratifiedKFold`` over the training
        windows, not grouped by run; they see training windows only, never a test run.
        Folds grouped by run calibrate worse on held-out BorealTC runs (expected
        calibration error 0.116 against 0.045, accuracy 0.838 against 0.865, seeds 0-2:
        ``benchmarks/svm_calibration_folds.py``, docs/model_comparison.md).
    search_C, search_gamma : tuple
        Grid of the nested search.
    inner_splits : int
        Folds of the inner (grouped) search.

    Raises
    ------
    ConfigError
        ``probability`` not True or False; ``C`` or a ``search_C`` value not a finite
        number > 0; ``gamma`` or a ``search_gamma`` value neither ``"scale"``, ``"auto"``
        nor a finite number > 0; an empty grid; ``inner_splits`` not an integer >= 2.
    """

    C: float = 30.0
    gamma: float | str = "scale"
    probability: bool = False
    search_C: tuple[float, ...] = (3.0, 10.0, 30.0, 100.0)
    search_gamma: tuple[float | str, ...] = ("scale", 0.003, 0.01)
    inner_splits: int = 3

    def __post_init__(self) -> None:
        # C <= 0 or an unknown gamma reached SVC's InvalidParameterError at the first fit,
        # gamma 0 fitted a constant kernel, and inner_splits 1 or an empty grid raised
        # scikit-learn's bare ValueError inside the CV, after the data was windowed
        # a text such as "no" from a config file was truthy and calibrated the SVC
        config_flags("SVMConfig", probability=self.probability)
        config_positive("SVMConfig", C=self.C)
        _check_gamma("gamma", self.gamma)
        config_integer("SVMConfig.inner_splits", self.inner_splits, 2)
        for name, grid in (("search_C", self.search_C), ("search_gamma", self.search_gamma)):
            if isinstance(grid, str) or not hasattr(grid, "__len__") or len(grid) == 0:
                raise ConfigError(f"SVMConfig.{name} must be a non-empty sequence, got {grid!r}")
        for c in self.search_C:
            config_positive("SVMConfig", search_C=c)
        for gamma in self.search_gamma:
            _check_gamma("search_gamma", gamma)
        # the caller's list was kept: changing it later changed the validated grid
        for name in ("search_C", "search_gamma"):
            object.__setattr__(self, name, tuple(getattr(self, name)))


def _check_gamma(name: str, gamma) -> None:
    """Refuse an RBF width that is neither ``"scale"``, ``"auto"`` nor a finite number > 0
    (:class:`~terrain.errors.ConfigError` naming ``SVMConfig.<name>``)."""
    if isinstance(gamma, str):
        if gamma not in ("scale", "auto"):
            raise ConfigError(f"SVMConfig.{name} must be 'scale', 'auto' or a finite number "
                              f"> 0, got {gamma!r}")
        return
    config_positive("SVMConfig", **{name: gamma})


def make_svm(config: SVMConfig = SVMConfig(), random_state: int = 0) -> Pipeline:
    """``StandardScaler`` + RBF ``SVC`` (``class_weight="balanced"``) as one pipeline.

    Parameters
    ----------
    config : SVMConfig
        ``C``, ``gamma`` and whether to calibrate probabilities (Platt scaling).
    random_state : int
        Seed of the SVC (passed to every calibrated copy too).

    Returns
    -------
    sklearn.pipeline.Pipeline
        Unfitted ``scale -> svc`` pipeline over ``(n_windows, n_features)`` features; ``svc``
        is a ``CalibratedClassifierCV`` when ``config.probability``.
    """
    svc = SVC(C=config.C, gamma=config.gamma, kernel="rbf", class_weight="balanced",
              random_state=random_state)
    if config.probability:
        svc = CalibratedClassifierCV(svc, method="sigmoid", ensemble=False)
    return Pipeline([("scale", StandardScaler()), ("svc", svc)])


class GroupedSearch(GridSearchCV):
    """``GridSearchCV`` over inner folds grouped by run (:func:`make_search`) that refuses
    fewer runs than folds with a :class:`~terrain.errors.ConfigError` (scikit-learn's own
    error names neither the runs nor the setting). Parameters as for ``GridSearchCV``.
    """

    def fit(self, X, y=None, **params):
        """Check the runs, then fit as ``GridSearchCV.fit``.

        Parameters
        ----------
        X : array-like
            ``(n_windows, n_features)`` training features.
        y : array-like or None
            ``(n_windows,)`` labels.
        **params : dict
            Fit parameters; ``groups``: ``(n_windows,)`` the windows' runs (split units).

        Returns
        -------
        GroupedSearch
            ``self``.

        Raises
        ------
        ConfigError
            Fewer runs than inner folds (``SVMConfig.inner_splits``), ``groups`` missing
            included (the message names the runs), or every class with fewer windows than
            inner folds.
        MixedTypesError
            Values of types that do not sort together (text or booleans beside numbers) in ``y`` or
            ``groups`` (:func:`~terrain.models.cv.require_runs`)
            (:func:`terrain.errors.refuse_mixed_types`).
        """
        require_runs(params.get("groups"), self.cv.get_n_splits(),
                     "the grouped hyperparameter search", "SVMConfig.inner_splits",
                     labels=y)
        return super().fit(X, y, **params)


def make_search(config: SVMConfig = SVMConfig(), random_state: int = 0,
                n_jobs: int | None = None) -> GroupedSearch:
    """Grid search over C and gamma with inner folds grouped by run.

    Call ``fit(X, y, groups=groups)``: the inner ``StratifiedGroupKFold`` only ever splits the
    training runs it is given, so tuning never sees a test run; fewer runs than
    ``config.inner_splits`` are a :class:`~terrain.errors.ConfigError` at ``fit``
    (:class:`GroupedSearch`).

    Parameters
    ----------
    config : SVMConfig
        Grid (``search_C``, ``search_gamma``), inner fold count and the base settings of
        :func:`make_svm`.
    random_state : int
        Seed of the inner split shuffling and of the SVC.
    n_jobs : int or None
        joblib workers of the grid search.

    Returns
    -------
    GroupedSearch
        Unfitted ``GridSearchCV`` scored by macro F1, refitted on the whole training split
        with the best ``svc__C`` and ``svc__gamma`` (``svc__estimator__C`` and
        ``svc__estimator__gamma`` with ``config.probability``: the SVC inside the
        calibration).
    """
    inner = StratifiedGroupKFold(config.inner_splits, shuffle=True, random_state=random_state)
    # with probability the step is a CalibratedClassifierCV: its SVC is svc__estimator
    # (svc__C raised scikit-learn's bare "Invalid parameter 'C'" at the search's first fit)
    svc = "svc__estimator__" if config.probability else "svc__"
    grid = {f"{svc}C": list(config.search_C), f"{svc}gamma": list(config.search_gamma)}
    return GroupedSearch(make_svm(config, random_state), grid, cv=inner, scoring="f1_macro",
                         n_jobs=n_jobs, refit=True)


def _pair_matrices(n_classes: int) -> tuple[np.ndarray, np.ndarray]:
    """``(n_pairs, n_classes)`` one-hot rows of the first and second class of each one-vs-one
    pair, in libsvm's order ``(0, 1), (0, 2), ..., (n-2, n-1)``."""
    pairs = [(i, j) for i in range(n_classes) for j in range(i + 1, n_classes)]
    first = np.zeros((len(pairs), n_classes))
    second = np.zeros((len(pairs), n_classes))
    for k, (i, j) in enumerate(pairs):
        first[k, i] = 1.0
        second[k, j] = 1.0
    return first, second


@dataclass(frozen=True)
class _CalibratedRBF:
    """Arrays of a fitted ``CalibratedClassifierCV(SVC(kernel="rbf"), "sigmoid",
    ensemble=False)`` for :func:`calibrated_rbf_proba` (see there)."""

    support_vectors: np.ndarray
    support_sq_norms: np.ndarray
    pair_coef: np.ndarray
    intercept: np.ndarray
    gamma: float
    first: np.ndarray
    second: np.ndarray
    sigmoid_a: np.ndarray
    sigmoid_b: np.ndarray
    columns: np.ndarray
    n_classes: int


def _calibrated_rbf_arrays(calibrated) -> _CalibratedRBF | None:
    """The arrays of :class:`_CalibratedRBF`, or ``None`` when ``calibrated`` is not a fitted
    single sigmoid-calibrated multiclass RBF ``SVC`` (the fast path does not apply)."""
    ccs = getattr(calibrated, "calibrated_classifiers_", None)
    if (not isinstance(calibrated, CalibratedClassifierCV) or ccs is None or len(ccs) != 1
            or ccs[0].method != "sigmoid"):
        return None
    svc = ccs[0].estimator
    if (not isinstance(svc, SVC) or svc.kernel != "rbf" or svc.decision_function_shape != "ovr"
            or len(svc.classes_) < 3 or getattr(svc, "_sparse", True)):
        return None
    n_classes = len(svc.classes_)
    sv = np.asarray(svc.support_vectors_, dtype=float)
    # libsvm layout: the coefficient of support vector s (of class c(s)) in the pair (i, j)
    # is dual_coef[j - 1, s] when c(s) == i and dual_coef[i, s] when c(s) == j
    owner = np.repeat(np.arange(n_classes), svc.n_support_)
    first, second = _pair_matrices(n_classes)
    pair_coef = np.zeros((len(first), len(sv)))
    for k in range(len(first)):
        i, j = int(first[k].argmax()), int(second[k].argmax())
        pair_coef[k, owner == i] = svc._dual_coef_[j - 1, owner == i]
        pair_coef[k, owner == j] = svc._dual_coef_[i, owner == j]
    classes = list(calibrated.classes_)
    return _CalibratedRBF(
        support_vectors=sv, support_sq_norms=(sv * sv).sum(axis=1), pair_coef=pair_coef,
        intercept=np.asarray(svc._intercept_, dtype=float), gamma=float(svc._gamma),
        first=first, second=second,
        sigmoid_a=np.array([c.a_ for c in ccs[0].calibrators]),
        sigmoid_b=np.array([c.b_ for c in ccs[0].calibrators]),
        columns=np.array([classes.index(c) for c in svc.classes_]), n_classes=len(classes))


def calibrated_rbf_proba(Xs: np.ndarray, arrays: _CalibratedRBF) -> np.ndarray:
    """Class probabilities of a Platt-calibrated multiclass RBF SVC, in NumPy.

    The same computation as ``CalibratedClassifierCV.predict_proba`` over ``SVC`` in
    scikit-learn 1.9 (libsvm one-vs-one decision values, scikit-learn's one-vs-rest vote
    transform, one sigmoid ``1 / (1 + exp(a f + b))`` per class, normalised to sum 1) without
    its per-call input validation, which dominates the time of one window. Agrees with
    scikit-learn to rounding (tested).

    Parameters
    ----------
    Xs : numpy.ndarray
        ``(n_windows, n_features)`` standardised features.
    arrays : _CalibratedRBF
        Fitted arrays from :func:`_calibrated_rbf_arrays`.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_classes)`` probabilities, columns in the calibrated classifier's
        ``classes_`` order.
    """
    sq = (arrays.support_sq_norms[None, :] + (Xs * Xs).sum(axis=1)[:, None]
          - 2.0 * Xs @ arrays.support_vectors.T)
    kernel = np.exp(-arrays.gamma * np.maximum(sq, 0.0))
    dec = kernel @ arrays.pair_coef.T + arrays.intercept           # (n, n_pairs), libsvm
    votes = (dec >= 0) @ arrays.first + (dec < 0) @ arrays.second
    conf = dec @ arrays.first - dec @ arrays.second
    ovr = votes + conf / (3.0 * (np.abs(conf) + 1.0))
    sig = 1.0 / (1.0 + np.exp(arrays.sigmoid_a * ovr + arrays.sigmoid_b))
    proba = np.zeros((len(Xs), arrays.n_classes))
    proba[:, arrays.columns] = sig
    total = proba.sum(axis=1, keepdims=True)
    proba = np.divide(proba, total, out=np.full_like(proba, 1.0 / arrays.n_classes),
                      where=total != 0)
    proba[(proba > 1.0) & (proba <= 1.0 + 1e-5)] = 1.0
    return proba


def check_calibration_classes(step, y) -> None:
    """Refuse training labels a ``CalibratedClassifierCV`` step cannot calibrate on.

    Its ``cv`` (an integer, or ``None``: 5) stratified folds of the training windows give
    every class out-of-fold decision values only when each training part holds the class:
    scikit-learn raises a bare ``ValueError`` inside ``cross_val_predict`` for a class with
    a single window ("Only 2 class/es in training fold, but 3 in overall dataset"), and
    another when every class has fewer windows than folds.

    Parameters
    ----------
    step : estimator
        The final step of the pipeline; anything but a ``CalibratedClassifierCV`` with an
        integer or default ``cv`` is not checked.
    y : array-like or None
        ``(n_windows,)`` training labels; ``None``, a target that is not binary or
        multiclass labels, or a single class are left to scikit-learn's own errors.

    Raises
    ------
    ConfigError
        A class with one training window, or every class with fewer windows than the
        calibration's folds; the message names the classes and their windows.
    """
    if not isinstance(step, CalibratedClassifierCV) or y is None:
        return
    n_folds = 5 if step.cv is None else step.cv
    if not isinstance(n_folds, (int, np.integer)) or isinstance(n_folds, bool):
        return
    if type_of_target(y) not in ("binary", "multiclass"):
        return      # scikit-learn's own refusal of a target that is no class label
    classes, counts = np.unique(np.asarray(y), return_counts=True)
    if len(classes) < 2:
        return      # scikit-learn's own "one class" refusal
    single = classes[counts < 2].tolist()
    if single:
        raise ConfigError(f"the SVM's probability calibration (SVMConfig.probability) fits "
                          f"it on {n_folds} stratified folds of its training windows, and "
                          f"class(es) {single} have 1 training window: every class needs 2 "
                          f"at least (more runs or shorter windows of those classes)")
    if (counts < n_folds).all():
        raise ConfigError(f"the SVM's probability calibration (SVMConfig.probability) needs "
                          f"a class with as many training windows as its {n_folds} "
                          f"calibration folds; the largest has {counts.max()} (more runs or "
                          f"shorter windows)")


class SVMPipeline(CompiledPipeline):
    """``features -> scale -> calibrated SVC`` pipeline with a fast ``predict_proba``.

    A :class:`sklearn.pipeline.Pipeline` in every respect (parameters, fitting, cloning,
    pickling); ``predict_proba`` and ``predict`` of a fitted pipeline ending in
    ``StandardScaler`` and a sigmoid-calibrated multiclass RBF ``SVC`` run the scaler and the
    SVC in NumPy (:func:`calibrated_rbf_proba`), which brings one window from about 1.5 ms to
    well under 1 ms on this machine (``benchmarks/bench_models.py``). Any other final step
    uses scikit-learn's path.

    Parameters
    ----------
    steps : list of (str, estimator)
        As for ``Pipeline``.
    memory : None
        As for ``Pipeline``.
    transform_input : None
        As for ``Pipeline``.
    verbose : bool
        As for ``Pipeline``.
    """

    def fit(self, X, y=None, **params):
        """Fit every step (``Pipeline.fit``) and extract the arrays of the NumPy path.

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` input of the first step.
        y : array-like or None
            ``(n_windows,)`` labels.
        **params : dict
            Fit parameters, routed as by ``Pipeline.fit``.

        Returns
        -------
        SVMPipeline
            ``self``.

        Raises
        ------
        ConfigError
            A calibrated final step (``SVMConfig.probability``) and a class with a single
            training window, or every class with fewer windows than the calibration's
            folds (:func:`check_calibration_classes`).
        MixedTypesError
            Values of types that do not sort together (text or booleans beside numbers) in ``y``
            (:func:`terrain.errors.refuse_mixed_types`).
        """
        if y is not None:   # (scikit-learn's bare "Unknown label type: unknown")
            refuse_mixed_types(type(self).__name__, "y", y)
        check_calibration_classes(self.steps[-1][1], y)
        super().fit(X, y, **params)
        final = self.steps[-1][1]
        self._fast_arrays = (getattr(final, "calibrated_classifiers_", None),
                             _calibrated_rbf_arrays(final))
        return self

    def _compiled(self) -> _CalibratedRBF | None:
        """Arrays of the NumPy path, or ``None`` (scikit-learn's path): not fitted through
        this class, or the final step was replaced or refitted since."""
        cached = self.__dict__.get("_fast_arrays")
        final = self.steps[-1][1]
        if cached is None or cached[0] is not getattr(final, "calibrated_classifiers_", None):
            return None
        return cached[1]

    def _compiled_proba(self, compiled: _CalibratedRBF, Xt) -> np.ndarray:
        """:func:`calibrated_rbf_proba` of the scaled features; features that are not all
        finite (NaN passes the scaler) go to the fitted step, whose SVC refuses them with
        scikit-learn's error instead of a NaN row."""
        if not np.isfinite(Xt).all():
            return self.steps[-1][1].predict_proba(Xt)
        # float64 as the SVC casts it (no copy of float64 features)
        return calibrated_rbf_proba(np.asarray(Xt, dtype=np.float64), compiled)


def svm_window_pipeline(channels: Sequence[str], rate_hz: float, config: SVMConfig = SVMConfig(),
                        random_state: int = 0) -> SVMPipeline:
    """Unfitted ``features -> scaler -> SVC`` pipeline taking raw windows as input.

    The one place the window SVM of ``terrain cv``, ``terrain train`` and the registry is
    assembled.

    Parameters
    ----------
    channels : sequence of str
        Channel order of the windows' axis 1.
    rate_hz : float
        Window sampling rate, Hz.
    config : SVMConfig
        SVM hyperparameters (see :func:`make_svm`).
    random_state : int
        Seed of the SVC.

    Returns
    -------
    SVMPipeline
        ``features`` (:class:`features.transformers.WindowFeatures`) followed by the steps of
        :func:`make_svm`; input ``(n_windows, n_channels, n_samples)``; NumPy
        ``predict_proba`` for the calibrated SVC.
    """
    features = WindowFeatures(channels=tuple(channels), rate_hz=rate_hz)
    return SVMPipeline([("features", features)] + make_svm(config, random_state).steps)
