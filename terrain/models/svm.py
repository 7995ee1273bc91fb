"""SVM terrain classifier: ``StandardScaler`` + ``SVC`` with class balancing.

The thesis classifies terrain with an SVM on window features
(``001_59da564c4b2d6a48.txt`` ch. 8.1); BorealTC and Vulpi use an SVM on four statistical
moments as their classical baseline. Hyperparameters are tuned by :func:`make_search`, a grid
search whose inner folds are grouped by run and see training runs only.
"""

from __future__ import annotations

from dataclasses import dataclass

from sklearn.calibration import CalibratedClassifierCV
from sklearn.model_selection import GridSearchCV, StratifiedGroupKFold
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC


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
        probabilities, as needed for serving. Calibration folds are not grouped by run: it
        only shapes the probabilities, never an evaluation.
    search_C, search_gamma : tuple
        Grid of the nested search.
    inner_splits : int
        Folds of the inner (grouped) search.
    """

    C: float = 30.0
    gamma: float | str = "scale"
    probability: bool = False
    search_C: tuple[float, ...] = (3.0, 10.0, 30.0, 100.0)
    search_gamma: tuple[float | str, ...] = ("scale", 0.003, 0.01)
    inner_splits: int = 3


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


def make_search(config: SVMConfig = SVMConfig(), random_state: int = 0,
                n_jobs: int | None = None) -> GridSearchCV:
    """Grid search over C and gamma with inner folds grouped by run.

    Call ``fit(X, y, groups=groups)``: the inner ``StratifiedGroupKFold`` only ever splits the
    training runs it is given, so tuning never sees a test run.

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
    sklearn.model_selection.GridSearchCV
        Unfitted search scored by macro F1, refitted on the whole training split with the
        best ``svc__C`` and ``svc__gamma``.
    """
    inner = StratifiedGroupKFold(config.inner_splits, shuffle=True, random_state=random_state)
    grid = {"svc__C": list(config.search_C), "svc__gamma": list(config.search_gamma)}
    return GridSearchCV(make_svm(config, random_state), grid, cv=inner, scoring="f1_macro",
                        n_jobs=n_jobs, refit=True)
