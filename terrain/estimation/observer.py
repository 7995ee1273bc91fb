"""Adaptive identity observer for the track slip efficiencies eta_R, eta_L.

Seed ``000_f24201ff985633bf.txt`` (Tazzari, Azzollini, Marconi), eq. 8 with the kinematics
of eq. 5 (``eta = 1 - i``, eq. 4; half track ``d``)::

    d/dt [x^, y^, th^] = Phi(th)^T [eta_R^, eta_L^] + L e,         e = [x, y, th] - [x^, y^, th^]
    d/dt [eta_R^, eta_L^] = Lambda Phi(th) e

    Phi(th) = [[cos(th) v_R / 2,  sin(th) v_R / 2,  v_R / (2 d)],
               [cos(th) v_L / 2,  sin(th) v_L / 2, -v_L / (2 d)]]

with ``L = diag(l1, l2, l3)`` and ``Lambda = diag(lambda1, lambda2)`` positive definite.
The error system (eq. 10) is uniformly globally exponentially stable for constant track
speeds (Theorem 1). Inputs are the measured pose ``x, y, theta`` and the track (side) speeds
``v_R, v_L``; the estimator is integrated with forward Euler at the sample rate. Across a
time gap (a step longer than twice the median step) the correction of the sample before it
is integrated over one median step and the rest of the gap is predicted without correction
(``e = 0``, in steps of at most the median step), as over missing samples: one Euler step of
the correction over the whole gap multiplied the error by ``l3 h`` (a 1 s gap: the etas,
converged, jumped 0.25 away).

Two practical additions, stated: the estimates are projected onto ``eta_bounds`` after each
step (the seed's admissible range is 0 < eta < 2, eq. 4), and ``use_position=False`` gives a
*yaw-only* variant for recordings without a position sensor (the measured Husky runs): only
the third row of ``Phi`` and ``l3`` are used, with ``theta`` the integral of the
bias-corrected gyro. The yaw-only variant identifies ``eta_R v_R - eta_L v_L``, i.e. the
turning efficiency; the common part of ``eta_R, eta_L`` needs the position rows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrain.errors import (ConfigError, ShapeError, TimeStepError, config_flags,
                            config_numbers, config_positive, refuse_booleans, indexed)
from terrain.run import times_out_of_order
from terrain.vehicles.common import wrap_angle
from terrain.vehicles.skid_steer import HUSKY, body_rates, side_speeds


@dataclass(frozen=True)
class AdaptiveObserverSettings:
    """Gains and geometry of the observer of seed 000 eq. 8.

    Parameters
    ----------
    half_track_m : float
        ``d``, half the distance between the two wheel / track centre lines, m.
    l_gains : tuple of 3 float
        Output injection ``l1, l2, l3`` (1/s), > 0. The seed's experiments use 1 ("this
        also explains the convergence time", sec. V); the defaults were chosen on simulated
        Husky runs with 100 Hz samples (explicit Euler stays stable for
        ``lambda dt v^2 (1 + 1/d^2) / 4 < 2``).
    lambda_gains : tuple of 2 float
        Adaptation gains ``lambda1, lambda2``, > 0 (the seed uses 1).
    eta0 : tuple of 2 float
        Initial ``eta_R, eta_L``.
    eta_bounds : tuple of 2 float
        Projection interval of the estimates.
    use_position : bool
        Use the x, y rows (True) or the yaw row only (False).

    Raises
    ------
    ConfigError
        ``half_track_m`` or a gain not a finite number > 0, a tuple of the wrong length or
        holding something other than real numbers, ``eta_bounds`` not ``0 <= lo < hi``, or
        ``eta0`` not finite and inside ``eta_bounds``, or ``use_position`` not a boolean.
    """

    half_track_m: float = HUSKY.track_m / 2.0
    l_gains: tuple[float, float, float] = (2.0, 2.0, 10.0)
    lambda_gains: tuple[float, float] = (50.0, 50.0)
    eta0: tuple[float, float] = (1.0, 1.0)
    eta_bounds: tuple[float, float] = (0.02, 2.0)
    use_position: bool = True

    def __post_init__(self) -> None:
        # (a NaN gain or eta0 passed the range tests below and made every estimate NaN)
        owner = "AdaptiveObserverSettings"
        config_positive(owner, half_track_m=self.half_track_m)
        config_flags(owner, use_position=self.use_position)   # ("no" was read as on)
        for name, size in (("l_gains", 3), ("lambda_gains", 2), ("eta0", 2), ("eta_bounds", 2)):
            values = getattr(self, name)
            if np.ndim(values) != 1 or len(values) != size:
                raise ConfigError(f"{owner}.{name} needs {size} values, got {values!r}")
            config_numbers(owner, **indexed(name, values))
            if not isinstance(values, tuple):   # the caller's array or list, frozen
                object.__setattr__(self, name, tuple(float(v) for v in values))
        for name in ("l_gains", "lambda_gains"):
            config_positive(owner, **indexed(name, getattr(self, name)))
        lo, hi = self.eta_bounds
        if not 0 <= lo < hi:
            raise ConfigError(f"{owner}.eta_bounds must satisfy 0 <= lo < hi, got "
                              f"{self.eta_bounds}")
        if not all(lo <= v <= hi for v in self.eta0):
            raise ConfigError(f"{owner}.eta0 must lie in eta_bounds {self.eta_bounds} (the "
                              f"estimates are projected into them), got {self.eta0}")


@dataclass(frozen=True)
class ObserverResult:
    """Output of :func:`run_adaptive_observer` over N samples.

    Attributes
    ----------
    t_s : ndarray, shape (N,)
        Times, s.
    pose_hat : ndarray, shape (N, 3)
        Observer state ``x^, y^, theta^`` (m, m, rad).
    eta : ndarray, shape (N, 2)
        ``eta_R^, eta_L^`` (dimensionless).
    error : ndarray, shape (N, 3)
        Observation error ``e`` (eq. 9); NaN at a missing sample (no correction).
    """

    t_s: np.ndarray
    pose_hat: np.ndarray
    eta: np.ndarray
    error: np.ndarray

    @property
    def missing_samples(self) -> int:
        """Samples skipped for a non-finite value among those read (no correction: their
        ``error`` is NaN)."""
        return int(np.isnan(self.error[:, 2]).sum())

    @property
    def eta_right(self) -> np.ndarray:
        """``eta_R^`` over time, shape (N,)."""
        return self.eta[:, 0]

    @property
    def eta_left(self) -> np.ndarray:
        """``eta_L^`` over time, shape (N,)."""
        return self.eta[:, 1]


def _dead_reckon(x: float, y: float, theta: float, v_m_s: float, yaw_rate: float,
                 h_s: float, n_steps: int, use_position: bool) -> tuple[float, float, float]:
    """The observer's prediction without correction (``e = 0`` in eq. 8): the pose
    integrated over ``h_s`` seconds in ``n_steps`` forward Euler steps at body speed
    ``v_m_s`` (m/s) and yaw rate ``yaw_rate`` (rad/s); ``x, y`` stay as given when the
    position is not used."""
    hs = h_s / n_steps
    for _ in range(n_steps):
        if use_position:
            x += hs * math.cos(theta) * v_m_s
            y += hs * math.sin(theta) * v_m_s
        theta += hs * yaw_rate
    return x, y, theta


def run_adaptive_observer(t_s: np.ndarray, pose: np.ndarray, v_right_m_s: np.ndarray,
                          v_left_m_s: np.ndarray,
                          settings: AdaptiveObserverSettings = AdaptiveObserverSettings()
                          ) -> ObserverResult:
    """Integrate the adaptive observer (seed 000 eq. 8) over a recording.

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Sample times, s, strictly increasing; a step longer than twice the median one is a
        time gap, predicted without correction past its first median step (module
        docstring).
    pose : ndarray, shape (N, 3)
        Measured ``x, y`` (m, world frame) and ``theta`` (rad, unwrapped or wrapped: the
        heading error ``theta - theta^`` is wrapped to [-pi, pi), as an angle innovation of
        the EKFs is, :meth:`terrain.estimation.model.StateSpaceModel.residual`). With
        ``use_position=False`` only ``theta`` is read (x, y may be NaN). A sample with a
        non-finite value among those read or among its speeds is missing: no correction (its
        ``error`` is NaN), but the observer predicts over its step with its speeds, or the
        last finite ones (eq. 8 with ``e = 0``; over a time gap in steps of at most the
        median one, as after a sample it reads; holding the estimates instead lost the
        motion of the step, which the adaptive law made up by raising eta). Before the
        first sample it can read the estimates are held (it starts at that pose).
    v_right_m_s, v_left_m_s : ndarray, shape (N,)
        Track / side speeds ``omega r`` at the same times, m/s.
    settings : AdaptiveObserverSettings
        Gains and initial values.

    Returns
    -------
    ObserverResult

    Raises
    ------
    ShapeError
        Inconsistent shapes, no sample (the observer starts at the first pose), or booleans
        given for the times, the pose or the speeds.
    TimeStepError
        Times not finite and strictly increasing (the first such sample named).
    """
    # (a mask was read as a pose or speeds of 0 and 1)
    refuse_booleans(ShapeError, "adaptive observer", t_s=t_s, pose=pose,
                    v_right_m_s=v_right_m_s, v_left_m_s=v_left_m_s)
    t = np.asarray(t_s, dtype=float)
    p = np.asarray(pose, dtype=float)
    vr = np.asarray(v_right_m_s, dtype=float)
    vl = np.asarray(v_left_m_s, dtype=float)
    n = t.size
    if t.ndim != 1 or p.shape != (n, 3) or vr.shape != (n,) or vl.shape != (n,):
        raise ShapeError(f"need t (N,), pose (N, 3), v_right (N,), v_left (N,); got "
                         f"{t.shape}, {p.shape}, {vr.shape}, {vl.shape}")
    if n == 0:          # (numpy's bare "argmax of an empty sequence" below)
        raise ShapeError("adaptive observer: no sample (it starts at the first pose)")
    bad = times_out_of_order(t)      # (a NaN time passed ``dt <= 0``: NaN compares False)
    if bad.size:
        raise TimeStepError(f"observer sample times must be finite and increase strictly: "
                            f"sample {bad[0]} at {t[bad[0]]:.6g} s")
    dt = np.diff(t)
    # a step longer than twice the median is a gap: corrected over h_nom, then predicted
    h_nom = float(np.median(dt)) if dt.size else 0.0
    s = settings
    d = s.half_track_m
    l1, l2, l3 = s.l_gains
    lam_r, lam_l = s.lambda_gains
    lo, hi = s.eta_bounds
    use_pos = s.use_position
    # the observer starts at the first pose it can read (a missing first sample is held)
    start = p[int(np.argmax(np.isfinite(p if use_pos else p[:, 2:]).all(axis=1)))]
    xh, yh, th = (float(start[0]) if use_pos else 0.0, float(start[1]) if use_pos else 0.0,
                  float(start[2]))
    er, el = float(s.eta0[0]), float(s.eta0[1])
    pose_hat = np.empty((n, 3))
    eta = np.empty((n, 2))
    err = np.empty((n, 3))
    xs, ys, ths = p[:, 0].tolist(), p[:, 1].tolist(), p[:, 2].tolist()
    vrs, vls, dts = vr.tolist(), vl.tolist(), dt.tolist() + [0.0]
    started = False                  # from the first pose it reads (the start pose)
    a_last = b_last = math.nan       # the last finite speeds
    for k in range(n):
        theta, a, b = ths[k], vrs[k], vls[k]
        speeds = math.isfinite(a) and math.isfinite(b)
        if speeds:
            a_last, b_last = a, b
        pose_ok = math.isfinite(theta) and (
            not use_pos or (math.isfinite(xs[k]) and math.isfinite(ys[k])))
        started = started or pose_ok
        if not (speeds and pose_ok):
            # a missing sample: no correction; time passes, so the observer predicts over
            # the step (e = 0) with the speeds it has or the last finite ones (held before
            # the start, which is the first pose it reads, and before any finite speed)
            pose_hat[k] = (xh, yh, th)
            eta[k] = (er, el)
            err[k] = np.nan
            h = dts[k]
            if started and h > 0.0 and math.isfinite(a_last):
                v_g, w_g = body_rates(b_last * el, a_last * er, 2.0 * d, 1.0)   # eq. 5
                # a gap in steps of at most h_nom, as after a sample read (one Euler step
                # over a 1 s gap in a 0.5 rad/s turn put the pose 0.25 m off the arc)
                xh, yh, th = _dead_reckon(xh, yh, th, v_g, w_g, h,
                                          1 if h <= 2.0 * h_nom else math.ceil(h / h_nom),
                                          use_pos)
            continue
        c, sn = math.cos(theta), math.sin(theta)
        e_th = wrap_angle(theta - th)     # an angle: wrapped to [-pi, pi)
        if use_pos:
            e_x, e_y = xs[k] - xh, ys[k] - yh
        else:
            e_x = e_y = 0.0
        pose_hat[k] = (xh, yh, th)
        eta[k] = (er, el)
        err[k] = (e_x, e_y, e_th)
        h = dts[k]
        if h <= 0.0:
            break
        # eq. 8: observer and adaptive laws, explicit Euler
        v_g, w_g = body_rates(b * el, a * er, 2.0 * d, 1.0)     # eq. 5
        dx = c * v_g + l1 * e_x
        dy = sn * v_g + l2 * e_y
        dth = w_g + l3 * e_th
        der = lam_r * (0.5 * c * a * e_x + 0.5 * sn * a * e_y + a / (2.0 * d) * e_th)
        del_ = lam_l * (0.5 * c * b * e_x + 0.5 * sn * b * e_y - b / (2.0 * d) * e_th)
        h_c = h if h <= 2.0 * h_nom else h_nom
        if use_pos:
            xh += h_c * dx
            yh += h_c * dy
        th += h_c * dth
        er = min(max(er + h_c * der, lo), hi)
        el = min(max(el + h_c * del_, lo), hi)
        if h_c < h:
            # the rest of a time gap: predicted without correction (e = 0), as over
            # missing samples, in steps of at most h_nom
            v_g, w_g = body_rates(b * el, a * er, 2.0 * d, 1.0)     # eq. 5
            xh, yh, th = _dead_reckon(xh, yh, th, v_g, w_g, h - h_c,
                                      math.ceil((h - h_c) / h_nom), use_pos)
    return ObserverResult(t_s=t.copy(), pose_hat=pose_hat, eta=eta, error=err)


def eta_from_truth(v_body_m_s: np.ndarray, yaw_rate_rad_s: np.ndarray, v_right_m_s: np.ndarray,
                   v_left_m_s: np.ndarray, half_track_m: float,
                   min_speed_m_s: float = 0.1) -> np.ndarray:
    """True slip efficiencies from seed 000 eq. 15: ``eta_R = (V_G + d Omega) / v_R``,
    ``eta_L = (V_G - d Omega) / v_L``.

    Parameters
    ----------
    v_body_m_s, yaw_rate_rad_s : ndarray, shape (N,)
        True forward speed and yaw rate.
    v_right_m_s, v_left_m_s : ndarray, shape (N,)
        True rim speeds.
    half_track_m : float
        Half track width B/2, m.
    min_speed_m_s : float
        Rim speeds below this give NaN (eta undefined); a rim speed exactly at it gives
        eta. A rim speed of 0 gives NaN whatever the floor (with ``min_speed_m_s = 0`` it
        is not below it, but ``g / 0`` is no efficiency: it was inf).

    Returns
    -------
    ndarray, shape (N, 2)
        ``eta_R, eta_L``.

    Raises
    ------
    ConfigError
        ``half_track_m`` not a finite number > 0, or ``min_speed_m_s`` not a finite number
        >= 0 (NaN, a boolean or text included).
    """
    # (a NaN track or speed floor made every eta NaN, a negative track swapped the sides)
    config_positive("eta_from_truth", half_track_m=half_track_m)
    config_positive("eta_from_truth", allow_zero=True, min_speed_m_s=min_speed_m_s)
    v = np.asarray(v_body_m_s, dtype=float)
    w = np.asarray(yaw_rate_rad_s, dtype=float)
    vr = np.asarray(v_right_m_s, dtype=float)
    vl = np.asarray(v_left_m_s, dtype=float)
    true_l, true_r = side_speeds(v, w, 2.0 * half_track_m, 1.0)   # V_G -+ d Omega
    with np.errstate(divide="ignore", invalid="ignore"):
        er = np.where((np.abs(vr) >= min_speed_m_s) & (vr != 0.0), true_r / vr, np.nan)
        el = np.where((np.abs(vl) >= min_speed_m_s) & (vl != 0.0), true_l / vl, np.nan)
    return np.column_stack([er, el])
