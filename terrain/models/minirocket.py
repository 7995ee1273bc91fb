"""MiniRocket baseline (aeon) on raw windows, with class probabilities for serving.

MiniRocket (Dempster, Schmidt and Webb, KDD 2021) convolves every window with a fixed set of
random dilated kernels and keeps the proportion of positive values of each output; a linear
model on those features is a strong, cheap time-series baseline. The transform comes from
aeon (a well-kept library); the classifier here is a class-balanced logistic regression on
the standardised features (aeon's own ``MiniRocketClassifier`` uses a ridge classifier, which
gives no probabilities). The kernels' biases are quantiles of the training windows only.

Latency of one window (issue 13, ``benchmarks/bench_models.py``): aeon's numba transform costs
in proportion to the number of *dilations* (each dilation convolves every channel
combination once; the features of a dilation are cheap bias thresholds of that
convolution), not of features, so ``n_kernels`` barely changes it while
``max_dilations_per_kernel`` does. The scaler and the logistic regression are applied in NumPy
on one window (:class:`MiniRocketPipeline`), with scikit-learn's arithmetic.
"""

from __future__ import annotations

import importlib.util
import threading

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.linear_model import LogisticRegression
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from terrain.errors import ConfigError, config_integer
from terrain.models.compiled import CompiledPipeline

#: Fewest samples of a window MiniRocket transforms: its kernels span 9 samples (aeon refuses
#: shorter series).
MIN_WINDOW_SAMPLES = 9

#: Held by every fit while aeon seeds NumPy's global generator and draws the kernels from
#: it: two fits in threads of one process (joblib's threading backend) drew from one
#: another's seeded stream (other kernels than the seed's), and the caller's stream was left
#: at a fit's seeded state; under this lock they run one at a time, as sequential fits.
_NUMPY_RNG_LOCK = threading.RLock()


def require_aeon() -> None:
    """Refuse the ``minirocket`` model where its optional extra, aeon, is not installed.

    Called by :meth:`MiniRocketFeatures.fit` and, through
    :func:`terrain.models.registry.check_dependencies`, by the pipelines before any data is
    read or any MLflow run opens.

    Raises
    ------
    ConfigError
        aeon cannot be imported (with the command that installs it).
    """
    if importlib.util.find_spec("aeon") is None:
        raise ConfigError("the minirocket model needs aeon: pip install --no-deps "
                          "aeon==1.3.0 deprecated==1.3.1 (see README)")


def _signal_windows(X) -> np.ndarray:
    """``X`` as float32 windows; booleans (a mask handed over for the signals), no window
    or no channel, windows of fewer than :data:`MIN_WINDOW_SAMPLES` samples and values not
    finite in float32 refused (aeon refuses NaN only: inf gives finite features)."""
    X = np.asarray(X)
    # (aeon's bare IndexError "index 0 is out of bounds" for no window, NumPy's "a must be
    # greater than 0" for no channel)
    if (X.ndim == 3 and 0 in X.shape[:2]) or (X.ndim == 2 and not len(X)):
        raise ValueError(f"MiniRocket windows of shape {X.shape} hold no window or no "
                         "channel: give (n_windows, n_channels, n_samples) windows")
    # (aeon's "n_timepoints must be >= 9 ... zero pad shorter series", from inside every
    # fold's fit; the windowing cuts windows of 4 samples and more)
    if X.ndim in (2, 3) and X.shape[-1] < MIN_WINDOW_SAMPLES:
        raise ValueError(f"MiniRocket windows of {X.shape[-1]} samples: its kernels span "
                         f"{MIN_WINDOW_SAMPLES} samples, so it needs windows of "
                         f"{MIN_WINDOW_SAMPLES} samples or more (a longer window or a higher "
                         "rate)")
    if X.dtype.kind == "b":     # aeon would read them as 0.0 and 1.0
        raise ValueError("MiniRocket windows hold booleans (a mask?) where signal values are "
                         "expected")
    with np.errstate(over="ignore"):    # beyond float32: inf, refused below with its place
        X = np.asarray(X, dtype=np.float32)
    finite = np.isfinite(X)
    if not finite.all():
        where = [int(i) for i in np.argwhere(~finite)[0]]
        names = {2: ("window", "sample"), 3: ("window", "channel", "sample")}.get(X.ndim)
        at = ", ".join(f"{n} {i}" for n, i in zip(names, where)) if names else str(where)
        raise ValueError(f"MiniRocket windows hold {int((~finite).sum())} value(s) not finite "
                         f"in float32 (NaN, inf or beyond +-3.4e38), the first at {at}")
    return X


class MiniRocketFeatures(TransformerMixin, BaseEstimator):
    """scikit-learn transformer around aeon's ``MiniRocket`` (kept as the fitted ``rocket_``).

    aeon 1.3's estimators lack attributes scikit-learn 1.9's ``Pipeline`` sets on its steps,
    so the aeon object is held inside a plain scikit-learn transformer.

    Parameters
    ----------
    n_kernels : int
        Number of features (aeon rounds down to a multiple of 84; fewer than 84 give 84).
    max_dilations_per_kernel : int
        Upper bound on the dilations of each of the 84 kernels (aeon's default 32; the
        dilations are exponentially spaced up to ``(n_samples - 1) / 8`` samples and the
        features shared among them).
    n_jobs : int
        Threads of the transform.
    random_state : int
        Seed of the bias sampling, in [0, 2**32 - 1] (NumPy's range, as the split seeds);
        aeon's seeds are int32, so one of 2**31 or more is taken modulo 2**31.
    """

    def __init__(self, n_kernels: int = 10_000, max_dilations_per_kernel: int = 32,
                 n_jobs: int = 1, random_state: int = 0):
        self.n_kernels = n_kernels
        self.max_dilations_per_kernel = max_dilations_per_kernel
        self.n_jobs = n_jobs
        self.random_state = random_state

    def fit(self, X, y=None):
        """Draw the kernel biases from the training windows.

        NumPy's global random state is left as it was (aeon reseeds it to draw the
        biases; this puts the caller's stream back).

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
            aeon is not installed, or ``random_state`` not an integer in [0, 2**32 - 1].
        ValueError
            Boolean windows, no window or no channel, windows of fewer than
            :data:`MIN_WINDOW_SAMPLES` samples, or values not finite in float32.
        """
        require_aeon()
        try:
            from aeon.transformations.collection.convolution_based import MiniRocket
        except ImportError as exc:  # installed, but it or one of its imports is broken
            raise ConfigError(f"the minirocket model needs aeon, which does not import: "
                              f"{exc}") from exc
        # aeon seeds only a Python int (a NumPy integer drew the biases unseeded, True was
        # the seed 1) and casts it to int32 (2**31 and more: a bare OverflowError)
        config_integer("MiniRocketFeatures.random_state", self.random_state, 0, 2 ** 32 - 1)
        seed = int(self.random_state) % 2 ** 31
        X = _signal_windows(X)
        # aeon seeds NumPy's global generator with np.random.seed(seed) (its biases are
        # drawn from it): the caller's random stream was reset to the seed's by every fit
        with _NUMPY_RNG_LOCK:
            caller_stream = np.random.get_state()
            try:
                self.rocket_ = MiniRocket(
                    n_kernels=self.n_kernels,
                    max_dilations_per_kernel=self.max_dilations_per_kernel,
                    n_jobs=self.n_jobs, random_state=seed).fit(X)
            finally:
                np.random.set_state(caller_stream)
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

        Raises
        ------
        sklearn.exceptions.NotFittedError
            ``fit`` has not been called.
        ValueError
            Boolean windows, no window or no channel, windows of fewer than
            :data:`MIN_WINDOW_SAMPLES` samples, or values not finite in float32.
        """
        check_is_fitted(self, "rocket_")     # (was a bare AttributeError before fit)
        return np.asarray(self.rocket_.transform(_signal_windows(X)))


def softmax_logistic_proba(Z: np.ndarray, logreg: LogisticRegression) -> np.ndarray:
    """Multinomial class probabilities of a fitted logistic regression, in NumPy.

    ``LogisticRegression.predict_proba`` of scikit-learn 1.9 for three or more classes
    (``Z @ coef_.T + intercept_``, then its in-place softmax: subtract the row maximum,
    exponentiate, divide by the row sum) without its per-call input validation.

    Parameters
    ----------
    Z : numpy.ndarray
        ``(n_windows, n_features)`` standardised features.
    logreg : sklearn.linear_model.LogisticRegression
        Fitted, with three or more classes and a dense ``coef_``.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_classes)`` probabilities, columns in the order of ``logreg.classes_``.
    """
    proba = Z @ logreg.coef_.T + logreg.intercept_
    proba -= proba.max(axis=1).reshape(-1, 1)
    np.exp(proba, out=proba)
    proba /= proba.sum(axis=1).reshape(-1, 1)
    return proba


class MiniRocketPipeline(CompiledPipeline):
    """``MiniRocket -> scaler -> logistic regression`` with a NumPy ``predict_proba``.

    A :class:`sklearn.pipeline.Pipeline` in every respect (parameters, fitting, cloning,
    pickling). When the final step is a fitted multiclass ``LogisticRegression`` with dense
    coefficients, the scaler (:func:`terrain.models.compiled.scale_unchecked`) and the
    regression (:func:`softmax_logistic_proba`) skip scikit-learn's per-call input checks,
    with the same arithmetic (tested); otherwise scikit-learn's path runs. The MiniRocket
    transform itself is aeon's.

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

    def _compiled(self) -> LogisticRegression | None:
        """The fitted final logistic regression when the NumPy path applies, else ``None``."""
        final = self.steps[-1][1]
        if (isinstance(final, LogisticRegression)
                and isinstance(getattr(final, "coef_", None), np.ndarray)
                and len(final.classes_) >= 3 and final.coef_.shape[0] == len(final.classes_)):
            return final
        return None

    def _compiled_proba(self, compiled: LogisticRegression, Xt) -> np.ndarray:
        """:func:`softmax_logistic_proba` of the standardised features."""
        return softmax_logistic_proba(Xt, compiled)


def make_minirocket(random_state: int = 0, n_kernels: int = 10_000, C: float = 0.1,
                    n_jobs: int = 1, max_dilations_per_kernel: int = 32) -> MiniRocketPipeline:
    """Unfitted ``MiniRocket -> StandardScaler -> LogisticRegression`` pipeline.

    Parameters
    ----------
    random_state : int
        Seed of the kernel biases' sampling, in [0, 2**32 - 1] (see
        :class:`MiniRocketFeatures`).
    n_kernels : int
        Number of MiniRocket features (rounded down by aeon to a multiple of 84; fewer than
        84 give 84).
    C : float
        Inverse L2 regularisation of the logistic regression.
    n_jobs : int
        Threads of the aeon transform.
    max_dilations_per_kernel : int
        Dilations per kernel at most (see :class:`MiniRocketFeatures`); the single-window
        transform time grows with it.

    Returns
    -------
    MiniRocketPipeline
        Input: raw windows ``(n_windows, n_channels, n_samples)``; ``predict_proba`` gives
        class probabilities.
    """
    return MiniRocketPipeline([
        ("minirocket", MiniRocketFeatures(n_kernels=n_kernels,
                                          max_dilations_per_kernel=max_dilations_per_kernel,
                                          n_jobs=n_jobs, random_state=random_state)),
        ("scale", StandardScaler()),
        ("logreg", LogisticRegression(C=C, class_weight="balanced", max_iter=2000)),
    ])
