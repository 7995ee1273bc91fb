"""MiniRocket baseline (aeon) on raw windows, with class probabilities for serving.

MiniRocket (Dempster, Schmidt and Webb, KDD 2021) convolves every window with a fixed set of
random dilated kernels and keeps the proportion of positive values of each output; a linear
model on those features is a strong, cheap time-series baseline. The transform comes from
aeon (a well-kept library); the classifier here is a class-balanced logistic regression on
the standardised features (aeon's own ``MiniRocketClassifier`` uses a ridge classifier, which
gives no probabilities). The kernels' biases are quantiles of the training windows only.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from terrain.errors import ConfigError


class MiniRocketFeatures(TransformerMixin, BaseEstimator):
    """scikit-learn transformer around aeon's ``MiniRocket`` (kept as the fitted ``rocket_``).

    aeon 1.3's estimators lack attributes scikit-learn 1.9's ``Pipeline`` sets on its steps,
    so the aeon object is held inside a plain scikit-learn transformer.

    Parameters
    ----------
    n_kernels : int
        Number of features (aeon rounds down to a multiple of 84).
    n_jobs : int
        Threads of the transform.
    random_state : int
        Seed of the bias sampling.
    """

    def __init__(self, n_kernels: int = 10_000, n_jobs: int = 1, random_state: int = 0):
        self.n_kernels = n_kernels
        self.n_jobs = n_jobs
        self.random_state = random_state

    def fit(self, X, y=None):
        """Draw the kernel biases from the training windows.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, n_channels, n_samples)`` raw windows.
        y : ignored

        Returns
        -------
        self

        Raises
        ------
        ConfigError
            aeon is not installed.
        """
        try:
            from aeon.transformations.collection.convolution_based import MiniRocket
        except ImportError as exc:  # optional extra
            raise ConfigError("the minirocket model needs aeon: pip install --no-deps "
                              "aeon==1.3.0 deprecated==1.3.1 (see README)") from exc
        X = np.asarray(X, dtype=np.float32)
        self.rocket_ = MiniRocket(n_kernels=self.n_kernels, n_jobs=self.n_jobs,
                                  random_state=self.random_state).fit(X)
        self.n_features_in_ = X.shape[1]
        return self

    def transform(self, X):
        """MiniRocket features.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, n_channels, n_samples)`` raw windows.

        Returns
        -------
        numpy.ndarray
            ``(n_windows, n_features)``.
        """
        return np.asarray(self.rocket_.transform(np.asarray(X, dtype=np.float32)))


def make_minirocket(random_state: int = 0, n_kernels: int = 10_000, C: float = 0.1,
                    n_jobs: int = 1) -> Pipeline:
    """Unfitted ``MiniRocket -> StandardScaler -> LogisticRegression`` pipeline.

    Parameters
    ----------
    random_state : int
        Seed of the kernel biases' sampling.
    n_kernels : int
        Number of MiniRocket features (rounded down by aeon to a multiple of 84).
    C : float
        Inverse L2 regularisation of the logistic regression.
    n_jobs : int
        Threads of the aeon transform.

    Returns
    -------
    sklearn.pipeline.Pipeline
        Input: raw windows ``(n_windows, n_channels, n_samples)``; ``predict_proba`` gives
        class probabilities.

    """
    return Pipeline([
        ("minirocket", MiniRocketFeatures(n_kernels=n_kernels, n_jobs=n_jobs,
                                          random_state=random_state)),
        ("scale", StandardScaler()),
        ("logreg", LogisticRegression(C=C, class_weight="balanced", max_iter=2000)),
    ])
