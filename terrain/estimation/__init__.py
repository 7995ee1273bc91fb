"""State estimation: a generic EKF core, vehicle models, an adaptive slip observer and
consistency statistics.

Public API (see each module): :func:`predict`, :func:`update`, :func:`correct`,
:class:`Innovation`, :class:`Gate`, :class:`ExtendedKalmanFilter` (:mod:`.ekf`);
:class:`StateSpaceModel` (:mod:`.model`); :class:`SensorSamples`, :class:`EKFResult`,
:func:`run_filter`, :func:`make_grid` (:mod:`.runner`; result records in :mod:`.result`);
:func:`ema_filter` (:mod:`.prefilter`). The models' equations are written once, as numba
kernels, in :mod:`.equations` (shared by the NumPy models and the compiled loop of
:mod:`.fast`); the model classes live in :mod:`.agrimaro`, :mod:`.slip_state`,
:mod:`.skid_steer`; the adaptive observer of seed 000 in :mod:`.observer`; NEES / NIS in
:mod:`.consistency`.
"""

from __future__ import annotations

from terrain.estimation.ekf import (ExtendedKalmanFilter, Gate, Innovation, correct, predict,
                                    update)
from terrain.estimation.model import StateSpaceModel, wrap_angle
from terrain.estimation.prefilter import ema_filter, robust_noise_std
from terrain.estimation.result import EKFResult
from terrain.estimation.runner import SensorSamples, make_grid, run_filter

__all__ = ["ExtendedKalmanFilter", "Gate", "Innovation", "correct", "predict", "update",
           "StateSpaceModel", "wrap_angle", "ema_filter", "robust_noise_std", "EKFResult",
           "SensorSamples", "make_grid", "run_filter"]
