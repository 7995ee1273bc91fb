"""A window classifier that also sees the skid-steer EKF's channels of each window.

The signal set ``all+ekf`` runs the EKF over each whole run before windowing, so its slow
states (ICR expansion chi, gyro bias) carry the run's past into every window: on a stream
that switches terrain they hold the previous terrain (docs/streaming.md, "EKF channels
across switches"). :class:`WindowEKFClassifier` instead computes the EKF channels from each
window's own samples (:func:`features.ekf_signals.window_ekf_channels`, the filter started
from its prior at the window's first sample) and appends them to the window before the
wrapped classifier. Nothing older than the window enters, so the model is a stateless
function of the window, like every other model of :mod:`terrain.models.registry`, and is
served unchanged by :mod:`terrain.serving`.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.utils.validation import check_is_fitted

from features.ekf_signals import EKF_CHANNELS, window_ekf_channels
from features.windows import HUSKY_TRACK_M
from terrain.errors import EstimationError, refuse_booleans
from terrain.estimation.skid_steer import SkidSteerSettings
from terrain.models.cv import fit_with_groups


class WindowEKFClassifier(ClassifierMixin, BaseEstimator):
    """``estimator`` fed each window with :data:`~features.ekf_signals.EKF_CHANNELS` appended.

    Parameters
    ----------
    estimator : classifier
        Unfitted scikit-learn classifier taking windows ``(n_windows, n_channels +
        len(EKF_CHANNELS), n_samples)`` whose channels are ``channels`` then ``EKF_CHANNELS``.
    channels : tuple of str
        Channel order of the input windows' axis 1 (``vel_l``, ``vel_r``, ``wz`` among them).
    rate_hz : float
        Sampling rate of the windows, Hz.
    wheel_rate_hz : float or None
        Native rate of the wheel stream, Hz (the EKF's wheel-variance inflation, see
        :func:`~terrain.estimation.skid_steer.skid_steer_on_windows`).
    track_m : float
        Track width B of the vehicle whose windows these are, m (the filter's skid-steer
        kinematics; default the Husky's, :data:`features.windows.HUSKY_TRACK_M`).

    Attributes
    ----------
    estimator_ : classifier
        The fitted clone of ``estimator``.
    classes_ : numpy.ndarray
        Its classes.
    n_features_in_ : int
        ``X.shape[1]`` in ``fit``: the channels of the input windows (``len(channels)``;
        the wrapped classifier sees ``len(EKF_CHANNELS)`` more).

    Notes
    -----
    Source of the filter: :mod:`terrain.estimation.skid_steer` (ICR model of Mandow et al.
    2007; seed ``000_f24201ff985633bf.txt`` eq. 3). The windows must be gap-free (the
    windowing step drops windows holding gaps).
    """

    def __init__(self, estimator, channels: tuple[str, ...] = (), rate_hz: float = 100.0,
                 wheel_rate_hz: float | None = None, track_m: float = HUSKY_TRACK_M):
        self.estimator = estimator
        self.channels = channels
        self.rate_hz = rate_hz
        self.wheel_rate_hz = wheel_rate_hz
        self.track_m = track_m

    def augment(self, X: np.ndarray) -> np.ndarray:
        """The windows with their EKF channels appended.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, len(channels), n_samples)``.

        Returns
        -------
        numpy.ndarray
            ``(n_windows, len(channels) + len(EKF_CHANNELS), n_samples)``.

        Raises
        ------
        terrain.errors.EstimationError
            ``X`` holds booleans (a mask handed over for the signals: cast here, they would
            reach the filter and the wrapped model as 0.0 and 1.0).
        terrain.errors.DataFormatError, terrain.errors.ShapeError,
        terrain.errors.NonFiniteInputError
            See :func:`features.ekf_signals.window_ekf_channels`.
        """
        refuse_booleans(EstimationError, type(self).__name__, X=X)
        X = np.asarray(X, dtype=float)
        ekf = window_ekf_channels(X, self.channels, self.rate_hz,
                                  wheel_rate_hz=self.wheel_rate_hz,
                                  settings=SkidSteerSettings(track_m=self.track_m))
        return np.concatenate([X, ekf], axis=1)

    @property
    def augmented_channels(self) -> tuple[str, ...]:
        """Channel order the wrapped classifier sees: ``channels`` then the EKF channels."""
        return tuple(self.channels) + tuple(EKF_CHANNELS)

    def fit(self, X: np.ndarray, y: np.ndarray, groups: np.ndarray | None = None):
        """Fit the wrapped classifier on the augmented windows.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, len(channels), n_samples)`` windows.
        y : numpy.ndarray
            ``(n_windows,)`` labels.
        groups : numpy.ndarray, optional
            ``(n_windows,)`` runs, passed on when the wrapped ``fit`` takes them (ensembles
            with tuned weights, CNNs with early stopping).

        Returns
        -------
        WindowEKFClassifier
            ``self``.
        """
        augmented = self.augment(X)
        est = fit_with_groups(clone(self.estimator), augmented, y, groups)
        self.estimator_ = est
        self.classes_ = est.classes_
        self.n_features_in_ = augmented.shape[1] - len(EKF_CHANNELS)
        return self

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        """Class probabilities of the windows, ``(n_windows, n_classes)``, ``classes_`` order.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, len(channels), n_samples)``.

        Returns
        -------
        numpy.ndarray
        """
        check_is_fitted(self, "estimator_")
        return self.estimator_.predict_proba(self.augment(X))

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Predicted class of each window, ``(n_windows,)``.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, len(channels), n_samples)``.

        Returns
        -------
        numpy.ndarray
        """
        check_is_fitted(self, "estimator_")
        return self.estimator_.predict(self.augment(X))


__all__ = ["WindowEKFClassifier"]
