"""MiniRocket baseline (aeon) on raw windows, with class probabilities for serving.

MiniRocket (Dempster, Schmidt and Webb, KDD 2021) convolves every window with a fixed set of
random dilated kernels and keeps the proportion of positive values of each output; a linear
model on those features is a strong, cheap time-series baseline. The transform comes from
aeon (a well-kept library); the classifier here is a class-balanced logistic regression on
the standardised features (aeon's own ``MiniRocketClassifier`` uses a ridge classifier, which
gives no probabilities). The kernels' biases are quantiles of the training windows only.
"""

from __future__ import annotations

from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from terrain.errors import ConfigError


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

    Raises
    ------
    ConfigError
        aeon is not installed (``pip install terrain[minirocket]``, see README).
    """
    try:
        from aeon.transformations.collection.convolution_based import MiniRocket
    except ImportError as exc:  # optional extra
        raise ConfigError("the minirocket model needs aeon: pip install --no-deps "
                          "aeon==1.3.0 (see README, 'Model comparison')") from exc
    return Pipeline([
        ("minirocket", MiniRocket(n_kernels=n_kernels, n_jobs=n_jobs,
                                  random_state=random_state)),
        ("scale", StandardScaler()),
        ("logreg", LogisticRegression(C=C, class_weight="balanced", max_iter=2000)),
    ])
