"""Skid-steer EKF with per-side longitudinal slip fused from a slip model (issue 10 item 4).

State (8)::

    x = [v_bx, yaw_rate, b_g, ln(chi), s_1, s_2, a_x, pitch]
         m/s   rad/s     rad/s 1       1    1    m/s^2 rad

Equations: :mod:`terrain.estimation.equations.skid_steer_slip` (the wheel and gyro rows are
those of :mod:`terrain.estimation.equations.skid_steer`, with each side's rim speed its
ground speed over ``1 - s_i``). With wheels and a gyro only, the common slip of both sides and
the forward speed are not separable (``docs/estimation_validation.md``). Two sources close the
gap:

* a **slip model** (:mod:`terrain.slip.physics` or :mod:`terrain.slip.learned`) enters as a
  pseudo-measurement of ``s_1, s_2`` with the model's own standard deviation. The engine of
  :func:`terrain.estimation.runner.run_filter` has a constant diagonal ``R``; a time-varying
  pseudo-measurement variance is handled by running it in segments, one per pseudo-measurement
  sample, each with that sample's variance, the state and covariance handed from one segment
  to the next (:func:`run_with_pseudo_slip`). No model equation is re-typed here;
* the **accelerometer** (specific force ``ax = a_x + g sin(pitch)``, ``az = g cos(pitch)``)
  drives ``v_bx`` through ``a_x`` in transients, so the speed follows accelerations faster than
  the window-mean slip pseudo-measurement can.

Without a pseudo-measurement the slip states keep their prior (0 with ``slip0_std``) plus
their random-walk growth: the reported standard deviation then says that the slip is not
observable, instead of a confident 0. The slip states are kept in their physical range
[-1, 1] (:attr:`SkidSteerSlipModel.state_bounds`, applied by
:func:`~terrain.estimation.runner.run_filter` after every update).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, Mapping

import numpy as np
import pandas as pd

from terrain.errors import ConfigError, ShapeError, config_numbers
from terrain.estimation.ekf import Gate
from terrain.estimation.equations.skid_steer_slip import (N_MEASUREMENTS, N_STATES,
                                                          SkidSteerSlipEquationParams,
                                                          observation_into, transition_into)
from terrain.estimation.equations.evaluate import NO_INPUT, observation_pair, transition_pair
from terrain.estimation.model import StateSpaceModel
from terrain.estimation.result import EKFResult
from terrain.estimation.runner import (SensorSamples, run_filter, sample_steps,
                                       samples_inside)
from terrain.run import clock_slack, step_index
from terrain.terramechanics.slip import ground_speed_from_slip
from terrain.vehicles.skid_steer import HUSKY

if TYPE_CHECKING:
    from terrain.estimation.fast import FastKernel

STATE_NAMES: tuple[str, ...] = ("v_bx", "yaw_rate", "gyro_bias", "log_icr_chi", "slip_1",
                                "slip_2", "accel_x", "pitch")
MEASUREMENT_NAMES: tuple[str, ...] = ("vel_l", "vel_r", "wz", "slip_1", "slip_2", "ax", "az")
SENSOR_ROWS: Mapping[str, tuple[int, ...]] = MappingProxyType(
    {"wheels": (0, 1), "gyro": (2,), "slip_model": (3, 4), "accel": (5, 6)})
#: Rim-speed noise margin of the speed bound (:func:`speed_bounds_m_s`), in wheel noise
#: standard deviations (``SkidSteerSlipSettings.wheel_std_m_s``): 3, two-sided 99.7 %.
SPEED_BOUND_NOISE_STDS = 3.0
#: States the speed bound may move: the forward speed and the two side slips, the states along
#: the direction the wheels cannot see (``v (1 - s) = omega r``); the projection holds the
#: others (yaw rate, gyro bias, ``ln chi``, acceleration, pitch), which a kinematic speed
#: range says nothing about (:func:`terrain.estimation.ekf.project_to_bounds`, ``movable``)
SPEED_BOUND_STATES: tuple[str, ...] = ("v_bx", "slip_1", "slip_2")
SPEED_BOUND_MOVABLE = np.isin(STATE_NAMES, SPEED_BOUND_STATES)
SPEED_BOUND_MOVABLE.flags.writeable = False


@dataclass(frozen=True)
class SkidSteerSlipSettings:
    """Geometry and tuning of the slip-augmented skid-steer EKF.

    Parameters
    ----------
    track_m : float
        Geometric track width B, m (Husky 0.5708 m).
    wheel_std_m_s : float
        Noise of a side's rim speed, m/s (as in
        :class:`~terrain.estimation.skid_steer.SkidSteerSettings`).
    gyro_std_rad_s : float
        Gyro z noise, rad/s.
    accel_std_m_s2 : float
        Accelerometer noise including vibration and the unmodelled centripetal and vertical
        accelerations, m/s^2 (ASSUMED 0.3: the simulated white noise is 0.05 m/s^2, terrain
        vibration adds several times that).
    jerk_psd : float
        Density of the jerk driving ``a_x``, (m/s^3)^2 s.
    yaw_accel_psd : float
        Density of the yaw acceleration, (rad/s^2)^2 s.
    bias_psd : float
        Gyro bias drift density, (rad/s)^2 / s.
    log_chi_psd : float
        Drift density of ``ln(chi)``, 1/s.
    slip_psd : float
        Drift density of each side's slip, 1/s (terrain and load changes; small: the slip
        follows the pseudo-measurement, one per second).
    slip_psd_rel : float
        Drift density per unit pseudo-measurement variance, 1/s. When > 0,
        :func:`run_with_pseudo_slip` runs each segment with the slip drift density
        ``slip_psd + slip_psd_rel * std^2`` (``std``: that segment's pseudo-measurement std).
        Reason: the physics std is the traction-coefficient std over the slope of the terrain's
        traction-slip curve (:func:`terrain.slip.physics.physics_slip`), and a change of the
        traction demand (load, grade, patchy ground) moves the slip by that change over the
        same slope, so the slip's drift and the pseudo-measurement's std shrink together on a
        stiff curve (asphalt, ice at low slip) and grow together on a soft one; ``slip_psd``
        is then the terrain-independent part. 0 (default): constant ``slip_psd`` (the online
        observer of the control loop).
    slip_psd_transient : float
        Drift density per unit variance of the slip change inside the segment's window, 1/s
        (``transient_std`` of :func:`run_with_pseudo_slip`: the traction that changed inside
        the window beyond the current noise,
        :func:`terrain.slip.physics.within_window_current_std`, over the slope of the curve).
        A steady drive leaves the slip where it is (small ``slip_psd_rel``: the filter
        averages many windows); a start, a spin or a step moves it, and this term lets the
        filter follow. 0 (default): no such term.
    pitch_psd : float
        Drift density of the pitch, rad^2 / s (grade changes).
    chi0, log_chi0_std, bias0_std, v0_std, yaw_rate0_std : float
        Priors as in :class:`~terrain.estimation.skid_steer.SkidSteerSettings`.
    slip0_std : float
        Prior standard deviation of each side's slip (prior mean 0).
    accel0_std : float
        Prior standard deviation of ``a_x``, m/s^2.
    pitch0_std : float
        Prior standard deviation of the pitch, rad.
    chi_min_yaw_rate_rad_s : float
        ``chi`` is corrected only where the estimated yaw rate is at least this in
        magnitude, rad/s (exactly at it: corrected).
    slip_std : float
        Standard deviation of the slip pseudo-measurement rows (set per segment by
        :func:`run_with_pseudo_slip` from the slip model's own std).
    speed_bound_braking_slip : float or None
        Deepest SAE braking slip, in (-1, 0], that :func:`speed_bounds_m_s` allows: the
        forward speed is kept within the range the recent rim speeds and this slip imply
        (:func:`run_with_pseudo_slip`, by estimate projection; the rim equation alone
        allows -0.95, a contact 20 times as fast as its rim). -0.3: the braking slip that
        holds the Husky on the scenarios' steepest grade, 15 deg, on the softest curve of
        the catalogue, Wong's snow (``mu = 0.469 (1 - exp(-s / 0.333))`` equals
        ``tan 15 deg = 0.268`` at ``|s| = 0.28``; :mod:`terrain.terramechanics.catalogue`);
        on simulated Husky runs with truth (seeds 0-2) it cut the speed RMSE more than -0.5
        did (``benchmarks/speed_bound.py``, ``docs/slip_learning.md`` "A bound on the
        forward speed"). None: no bound.
        :func:`run_with_pseudo_slip` (``terrain estimate``'s batch filter) and the online
        observer of the control loop (:class:`terrain.control.estimators.FusedSlipObserver`,
        sample by sample) apply it.
    speed_bound_hold_s : float
        Window over which the bound keeps the widest range of the rim speeds, s (``hold_s``
        of :func:`speed_bounds_m_s`). 1.0: with the latest rim speeds alone (0) the
        simulated truth left the bound in stops on the catalogue's ice (friction 0.05: up
        to 2.9 % of a run's steps, by up to 0.20 m/s), with a 1 s hold on no simulated run
        that did not slide off; the shipped runs' wheel stream is not aligned to the IMU to
        better than a fraction of a second either (``terrain.slip.alignment.gated_lag``: no
        clear lag on any BorealTC run).

    Raises
    ------
    ConfigError
        A field not a real number (text, a boolean; None except for
        ``speed_bound_braking_slip``), a standard deviation not > 0 or a density negative or
        not finite.
    """

    track_m: float = HUSKY.track_m
    wheel_std_m_s: float = 0.03
    gyro_std_rad_s: float = 0.01
    accel_std_m_s2: float = 0.3
    jerk_psd: float = 0.3
    yaw_accel_psd: float = 0.1
    bias_psd: float = 1e-8
    log_chi_psd: float = 2e-3
    slip_psd: float = 6e-6
    slip_psd_rel: float = 0.0
    slip_psd_transient: float = 0.0
    pitch_psd: float = 1e-3
    chi0: float = 1.5
    log_chi0_std: float = 1.0
    bias0_std: float = 0.01
    v0_std: float = 0.3
    yaw_rate0_std: float = 0.3
    slip0_std: float = 0.3
    accel0_std: float = 1.0
    pitch0_std: float = 0.3
    chi_min_yaw_rate_rad_s: float = 0.05
    slip_std: float = 0.1
    speed_bound_braking_slip: float | None = -0.3
    speed_bound_hold_s: float = 1.0

    def __post_init__(self) -> None:
        # text passed float() below and was kept as text; True was 1
        config_numbers("SkidSteerSlipSettings", optional=("speed_bound_braking_slip",),
                       **vars(self))
        for name in ("track_m", "wheel_std_m_s", "gyro_std_rad_s", "accel_std_m_s2", "chi0",
                     "log_chi0_std", "bias0_std", "v0_std", "yaw_rate0_std", "slip0_std",
                     "accel0_std", "pitch0_std", "slip_std"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v > 0):
                raise ConfigError(f"{name} must be > 0 and finite, got {v}")
        for name in ("jerk_psd", "yaw_accel_psd", "bias_psd", "log_chi_psd", "slip_psd",
                     "slip_psd_rel", "slip_psd_transient", "pitch_psd",
                     "chi_min_yaw_rate_rad_s", "speed_bound_hold_s"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v >= 0):
                raise ConfigError(f"{name} must be >= 0 and finite, got {v}")
        b = self.speed_bound_braking_slip
        if b is not None and not (-1.0 < float(b) <= 0.0):
            raise ConfigError(f"speed_bound_braking_slip must be in (-1, 0] or None, got {b}")

    @property
    def speed_bound_rim_margin_m_s(self) -> float:
        """Widening of each rim speed in the speed bound, m/s:
        :data:`SPEED_BOUND_NOISE_STDS` times ``wheel_std_m_s``."""
        return SPEED_BOUND_NOISE_STDS * self.wheel_std_m_s

    @property
    def q_diag(self) -> tuple[float, ...]:
        """Process noise densities per state (the ``Q = diag(q) dt`` of the model), shape (8,).

        ``v_bx`` has none of its own: it is driven by ``a_x``, whose jerk density is
        ``jerk_psd``.
        """
        return (0.0, self.yaw_accel_psd, self.bias_psd, self.log_chi_psd, self.slip_psd,
                self.slip_psd, self.jerk_psd, self.pitch_psd)


@dataclass(frozen=True)
class SkidSteerSlipModel(StateSpaceModel):
    """The 8-state model of the module docstring over
    :mod:`terrain.estimation.equations.skid_steer_slip`.

    Parameters
    ----------
    settings : SkidSteerSlipSettings
        Geometry and tuning (``slip_std`` is the pseudo-measurement std in force).

    Attributes
    ----------
    state_names : tuple of str
        :data:`STATE_NAMES` (8).
    measurement_names : tuple of str
        :data:`MEASUREMENT_NAMES` (7).
    """

    settings: SkidSteerSlipSettings = field(default_factory=SkidSteerSlipSettings)
    state_names: tuple[str, ...] = field(default=STATE_NAMES, init=False)
    measurement_names: tuple[str, ...] = field(default=MEASUREMENT_NAMES, init=False)
    _p: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        s = self.settings
        object.__setattr__(self, "_p", SkidSteerSlipEquationParams(
            track_m=float(s.track_m),
            chi_min_yaw_rate_rad_s=float(s.chi_min_yaw_rate_rad_s)).as_array())

    @property
    def sensor_rows(self) -> Mapping[str, tuple[int, ...]]:
        """Sensor -> measurement rows (:data:`SENSOR_ROWS`)."""
        return SENSOR_ROWS

    def transition(self, x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(f(x), F)`` of :func:`~terrain.estimation.equations.skid_steer_slip.transition_into`.

        Parameters
        ----------
        x : ndarray, shape (8,)
            State.
        dt : float
            Step, s.

        Returns
        -------
        fx : ndarray, shape (8,)
        F : ndarray, shape (8, 8)
        """
        return transition_pair(transition_into, x, NO_INPUT, dt, self._p, N_STATES)

    def f(self, x: np.ndarray, dt: float) -> np.ndarray:
        """Next state.

        Parameters
        ----------
        x : ndarray, shape (8,)
            State.
        dt : float
            Step, s.

        Returns
        -------
        ndarray, shape (8,)
        """
        return self.transition(x, dt)[0]

    def F(self, x: np.ndarray, dt: float) -> np.ndarray:
        """Jacobian of :meth:`f`.

        Parameters
        ----------
        x : ndarray, shape (8,)
            State.
        dt : float
            Step, s.

        Returns
        -------
        ndarray, shape (8, 8)
        """
        return self.transition(x, dt)[1]

    def Q(self, dt: float) -> np.ndarray:
        """``diag(settings.q_diag) dt``.

        Parameters
        ----------
        dt : float
            Step, s.

        Returns
        -------
        ndarray, shape (8, 8)
        """
        q = np.diag(np.asarray(self.settings.q_diag, dtype=float)) * dt
        # a_x enters v_bx over the step: the exact discretisation of white jerk on (v, a)
        j = self.settings.jerk_psd
        q[0, 0] = j * dt ** 3 / 3.0
        q[0, 6] = q[6, 0] = j * dt ** 2 / 2.0
        return q

    def observation(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(h(x), H(x))`` of
        :func:`~terrain.estimation.equations.skid_steer_slip.observation_into`.

        Parameters
        ----------
        x : ndarray, shape (8,)
            State.

        Returns
        -------
        hx : ndarray, shape (7,)
        H : ndarray, shape (7, 8)
        """
        return observation_pair(observation_into, x, self._p, N_MEASUREMENTS, N_STATES)

    def h(self, x: np.ndarray) -> np.ndarray:
        """Measurement ``[vel_l, vel_r, wz, slip_1, slip_2, ax, az]``.

        Parameters
        ----------
        x : ndarray, shape (8,)
            State.

        Returns
        -------
        ndarray, shape (7,)
        """
        return self.observation(x)[0]

    def H(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`h`.

        Parameters
        ----------
        x : ndarray, shape (8,)
            State.

        Returns
        -------
        ndarray, shape (7, 8)
        """
        return self.observation(x)[1]

    @property
    def R_diag(self) -> np.ndarray:
        """``[s_w^2, s_w^2, s_g^2, s_s^2, s_s^2, s_a^2, s_a^2]``, shape (7,)."""
        s = self.settings
        return np.array([s.wheel_std_m_s ** 2] * 2 + [s.gyro_std_rad_s ** 2]
                        + [s.slip_std ** 2] * 2 + [s.accel_std_m_s2 ** 2] * 2)

    @property
    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The slips ``s_1, s_2`` in their physical range [-1, 1] (SAE slip); the other
        states unbounded. Without it a pseudo-measurement at full slip with a tiny std pushed
        the states past +-1 (the rim equation clips at
        :data:`~terrain.estimation.equations.skid_steer_slip.MAX_SLIP` with no slip column,
        so nothing pulled them back): 43 % of the steps of BorealTC SANDY_LOAM/07 and 70 %
        of SNOW/05 had ``|slip| > 1``.

        Returns
        -------
        lower, upper : ndarray, shape (8,)
        """
        lower = np.full(N_STATES, -np.inf)
        upper = np.full(N_STATES, np.inf)
        lower[4:6], upper[4:6] = -1.0, 1.0
        return lower, upper

    @property
    def x0(self) -> np.ndarray:
        """``[0, 0, 0, ln(chi0), 0, 0, 0, 0]``, shape (8,)."""
        x = np.zeros(N_STATES)
        x[3] = math.log(self.settings.chi0)
        return x

    @property
    def P0(self) -> np.ndarray:
        """Prior covariance, shape (8, 8)."""
        s = self.settings
        return np.diag([s.v0_std ** 2, s.yaw_rate0_std ** 2, s.bias0_std ** 2,
                        s.log_chi0_std ** 2, s.slip0_std ** 2, s.slip0_std ** 2,
                        s.accel0_std ** 2, s.pitch0_std ** 2])

    def fast_kernel(self) -> FastKernel | None:
        """The model's kernels for :mod:`terrain.estimation.fast`; None, because ``Q`` couples
        ``v_bx`` and ``a_x`` (the compiled loop takes a diagonal ``Q``): the NumPy reference
        loop runs this model.

        Returns
        -------
        None
        """
        return None


def rim_speed_range_m_s(rim_m_s: np.ndarray, braking_slip: float, rim_margin_m_s: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Range of the forward speed that one pair of rim speeds allows (no hold).

    ``[(min(0, a_l) + min(0, a_r)), (max(0, b_l) + max(0, b_r))] / (2 (1 + s_b))`` with
    ``a = omega r - margin``, ``b = omega r + margin``: each side's contact moves in the
    direction of its rim and at most at the ground speed that the braking slip ``s_b``
    allows (:func:`speed_bounds_m_s` gives the model and the sources; it applies this to
    the latest sample at every filter step, the online slip observer of the closed loop to
    every wheel sample as it arrives).

    Parameters
    ----------
    rim_m_s : ndarray, shape (k, 2)
        Left and right rim speeds ``omega r``, m/s, finite.
    braking_slip : float
        Deepest SAE braking slip allowed, in (-1, 0] (not checked here).
    rim_margin_m_s : float
        Widening of each rim speed for its noise, m/s, >= 0.

    Returns
    -------
    lower, upper : ndarray, shape (k,)
        Speed range, m/s, ``lower <= 0 <= upper``.
    """
    r = np.asarray(rim_m_s, dtype=float).reshape(-1, 2)
    back = ground_speed_from_slip(np.maximum(rim_margin_m_s - r, 0.0), braking_slip)
    ahead = ground_speed_from_slip(np.maximum(r + rim_margin_m_s, 0.0), braking_slip)
    return -back.mean(axis=1), ahead.mean(axis=1)


def speed_bounds_m_s(t_grid_s: np.ndarray, wheels: SensorSamples | None,
                     braking_slip: float, rim_margin_m_s: float, hold_s: float = 0.0
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Range of the forward speed that the recent rim speeds allow at each filter step.

    In the model of this module each side's contact moves in the direction of its rim
    (``omega r = g / (1 - q)`` or ``g (1 + q)``, ``|q| < 1``: seed
    ``001_59da564c4b2d6a48.txt`` eqs. 7.1-7.2, :mod:`terrain.estimation.equations.skid_steer_slip`)
    and is at most as fast as the ground speed that the deepest braking slip ``s_b``
    allows, ``|omega r| / (1 + s_b)``
    (:func:`terrain.terramechanics.slip.ground_speed_from_slip`); the forward speed is the
    mean of the two sides' ground speeds (``g_{l,r} = v_bx -+ chi B yaw_rate / 2``). So, with
    each side's rim speed widened by ``rim_margin_m_s`` for its noise,
    ``v_bx`` lies in ``[(min(0, a_l) + min(0, a_r)), (max(0, b_l) + max(0, b_r))] / (2 (1 +
    s_b))``, ``a = omega r - margin``, ``b = omega r + margin``, each end widened to its
    extreme over the last ``hold_s`` seconds (a body that the wheels stop keeps going until
    the traction has braked it, and the wheel record may lag the body). The EKF's linearised
    update does not keep its estimate there: along the direction the wheels cannot see
    (``v (1 - s) = omega r``) the speed and the slips can run off together; on BorealTC
    SNOW/06 the speed reached 6.1 m/s where the rims never passed 0.56 m/s, the slip
    reading a reversal as braking at ``q = -0.95`` (``docs/slip_learning.md``).

    Parameters
    ----------
    t_grid_s : ndarray, shape (N,)
        Filter steps, s, increasing.
    wheels : SensorSamples or None
        ``vel_l, vel_r`` rim speeds, m/s, shape (k, 2); each sample holds from the first
        step at or after its time (where :func:`~terrain.estimation.runner.run_filter`
        places it) to the next sample's; a sample with a non-finite side is skipped.
    braking_slip : float
        Deepest SAE braking slip allowed, in (-1, 0].
    rim_margin_m_s : float
        Widening of each rim speed for its noise, m/s, >= 0.
    hold_s : float
        Each step's range also covers the ranges of the steps of the last ``hold_s``
        seconds, the window ``(t - hold_s, t]``, s, >= 0 (0: the latest sample's alone): a
        step ``hold_s`` back (to the placement rule's slack, :func:`terrain.run.clock_slack`:
        1 ns below 2**17 s, 64 units in the last place on an epoch clock) is outside it, so
        a hold of ``k`` grid steps covers the step and the ``k - 1`` before it.

    Returns
    -------
    lower, upper : ndarray, shape (N,)
        Speed range, m/s (``lower <= 0 <= upper``); ``-inf, inf`` before the first finite
        wheel sample (everywhere without one) and, with ``hold_s``, at the steps whose
        window reaches back before it.

    Raises
    ------
    ConfigError
        ``braking_slip`` outside (-1, 0], ``rim_margin_m_s`` or ``hold_s`` negative or not
        finite.
    """
    if not -1.0 < float(braking_slip) <= 0.0:
        raise ConfigError(f"braking_slip must be in (-1, 0], got {braking_slip}")
    for name, value in (("rim_margin_m_s", rim_margin_m_s), ("hold_s", hold_s)):
        if not (np.isfinite(value) and value >= 0):
            raise ConfigError(f"{name} must be >= 0 and finite, got {value}")
    t_grid_s = np.asarray(t_grid_s, dtype=float)
    lower = np.full(t_grid_s.size, -np.inf)
    upper = np.full(t_grid_s.size, np.inf)
    if wheels is None or not len(wheels.t_s):
        return lower, upper
    rim = np.asarray(wheels.values, dtype=float).reshape(len(wheels.t_s), 2)
    ok = np.isfinite(rim).all(axis=1)
    steps = sample_steps(t_grid_s, np.asarray(wheels.t_s, dtype=float)[ok])
    rim = rim[ok]
    if not rim.size:
        return lower, upper
    # the latest sample placed at or before each step
    latest = np.searchsorted(steps, np.arange(t_grid_s.size), side="right") - 1
    held = latest >= 0
    lower[held], upper[held] = rim_speed_range_m_s(rim[latest[held]], braking_slip,
                                                   rim_margin_m_s)
    if hold_s > 0:
        # the widest range over the window (t - hold_s, t] of each step; a window reaching a
        # step before the first sample (no range, -inf / inf) has none (pandas' rolling max
        # reads an infinite value as missing: those steps were NaN, which run_filter refused)
        # on a clock of whole ns, the window 1 ns shorter: a step hold_s back (to the
        # rounding of the clock) is outside it (the float seconds cut to ns put it in or out
        # by their rounding: a hold of 3 steps at 30 Hz held 3 or 4)
        # (shorter by the placement rule's slack, terrain.run.clock_slack, where a clock's
        # rounding exceeds 1 ns: on an epoch clock steps lie hundreds of ns off their
        # nominal times, and the step hold_s back was inside the window on half the steps)
        slack_ns = max(1, int(round(float(clock_slack(np.abs(t_grid_s).max())) * 1e9)))
        clock = pd.to_timedelta(np.round((t_grid_s - t_grid_s[0]) * 1e9).astype(np.int64),
                                unit="ns")
        window = pd.DataFrame({"back": np.where(held, -lower, 0.0),
                               "ahead": np.where(held, upper, 0.0),
                               "none": np.where(held, 0.0, 1.0)}, index=clock).rolling(
            pd.Timedelta(max(int(round(hold_s * 1e9)) - slack_ns, 1), unit="ns")).max()
        unbounded = window["none"].to_numpy() > 0.0
        lower = np.where(unbounded, -np.inf, -window["back"].to_numpy())
        upper = np.where(unbounded, np.inf, window["ahead"].to_numpy())
    return lower, upper


def run_with_pseudo_slip(t_grid_s: np.ndarray, samples: Mapping[str, SensorSamples],
                         settings: SkidSteerSlipSettings = SkidSteerSlipSettings(),
                         pseudo_t_s: np.ndarray | None = None,
                         pseudo_slip: np.ndarray | None = None,
                         pseudo_std: np.ndarray | None = None, *,
                         gate: Gate | None = None,
                         drift_std: np.ndarray | None = None,
                         transient_std: np.ndarray | None = None) -> EKFResult:
    """Run :class:`SkidSteerSlipModel` with a slip pseudo-measurement whose variance varies.

    The grid is cut after each pseudo-measurement time; segment ``j`` runs with
    ``slip_std = pseudo_std[j]`` (the std of the one pseudo-measurement it holds) and the slip
    drift density ``slip_psd + slip_psd_rel * drift_std[j]^2 + slip_psd_transient *
    transient_std[j]^2`` (:class:`SkidSteerSlipSettings`; ``drift_std`` defaults to
    ``pseudo_std``, ``transient_std`` to 0); it starts
    from the state and covariance of the previous segment predicted by one step.

    Parameters
    ----------
    t_grid_s : ndarray, shape (N,)
        Filter steps, s (:func:`terrain.estimation.runner.make_grid`).
    samples : Mapping[str, SensorSamples]
        ``wheels`` (``vel_l, vel_r`` m/s), ``gyro`` (``wz`` rad/s), ``accel`` (``ax, az``
        m/s^2); any may be missing.
    settings : SkidSteerSlipSettings
        Tuning.
    pseudo_t_s : ndarray, shape (k,), optional
        Times of the slip model's outputs, s, increasing (None: no pseudo-measurement); one
        outside the grid (:func:`~terrain.estimation.runner.samples_inside`) is counted as
        outside and sets no segment's noise.
    pseudo_slip : ndarray, shape (k, 2)
        Slip of sides 1 and 2 from the slip model; a non-finite side is left out of that
        update (the other side is used), a window with neither side finite is skipped; both
        are counted in ``counts["slip_model"]["non_finite"]``.
    pseudo_std : ndarray, shape (k, 2) or (k,)
        Its standard deviation (the larger of the sides used is used for both rows).
    gate : Gate, optional
        Chi-square gating per sensor.
    drift_std : ndarray, shape (k, 2) or (k,), optional
        Slip std that scales the drift density of segment ``j`` when
        ``settings.slip_psd_rel > 0`` (the larger side; non-finite: ``pseudo_std[j]``).
    transient_std : ndarray, shape (k, 2) or (k,), optional
        Slip change inside window ``j`` (std, the larger side; non-finite: 0) that scales
        ``settings.slip_psd_transient``; None: 0.

    Returns
    -------
    EKFResult
        Over the whole grid (full covariance kept: ``P`` of shape (N, 8, 8)).

    Raises
    ------
    ShapeError
        Pseudo-measurement arrays of inconsistent shapes.
    """
    t_grid_s = np.asarray(t_grid_s, dtype=float)
    base = dict(samples)
    bounds = _speed_bounds(t_grid_s, base.get("wheels"), settings)
    if pseudo_t_s is None or len(pseudo_t_s) == 0:
        return run_filter(SkidSteerSlipModel(settings), t_grid_s, base, gate=gate,
                          store_covariance=True, engine="numpy", step_bounds=bounds,
                          step_bound_movable=SPEED_BOUND_MOVABLE)
    tp = np.asarray(pseudo_t_s, dtype=float)
    sp = np.asarray(pseudo_slip, dtype=float)
    sd = np.asarray(pseudo_std, dtype=float)
    sd = sd.max(axis=1) if sd.ndim == 2 else sd
    dd = sd if drift_std is None else np.asarray(drift_std, dtype=float)
    dd = dd.max(axis=1) if dd.ndim == 2 else dd
    ts = np.zeros(tp.size) if transient_std is None else np.asarray(transient_std, float)
    ts = ts.max(axis=1) if ts.ndim == 2 else ts
    # (k,) or (k, 2) each: a (k, 3) array passed once reduced over its columns
    sides = all(np.ndim(a) < 2 or np.shape(a)[1] == 2
                for a in (pseudo_std, drift_std, transient_std))
    if not sides or sp.shape != (tp.size, 2) or sd.shape != (tp.size,) \
            or dd.shape != (tp.size,) or ts.shape != (tp.size,):
        raise ShapeError(f"pseudo-measurements need t (k,), slip (k, 2), std and drift std "
                         f"(k,) or (k, 2); got {tp.shape}, {sp.shape}, {np.shape(pseudo_std)}, "
                         f"{np.shape(drift_std)}, {np.shape(transient_std)}")
    # a side with a non-finite slip (e.g. skipped by the caller) leaves its row out of that
    # update; the other side's row is still used, with the std of the sides that are there
    sd2 = np.broadcast_to(np.asarray(pseudo_std, dtype=float).reshape(tp.size, -1),
                          (tp.size, 2))
    valid = np.isfinite(sp) & np.isfinite(sd2) & (sd2 > 0)
    sp = np.where(valid, sp, np.nan)
    sd = np.where(valid.all(axis=1), sd, np.max(np.where(valid, sd2, -np.inf), axis=1))
    # a window outside the grid is counted there and never used: it sets no segment's noise
    ok = valid.any(axis=1) & np.isfinite(sd) & (sd > 0) & samples_inside(t_grid_s, tp)
    # a window with neither side usable still reaches the filter, which skips and counts it
    base["slip_model"] = SensorSamples(tp, sp)
    tp, sp, sd = tp[ok], sp[ok], sd[ok]
    dd = np.where(np.isfinite(dd[ok]), dd[ok], sd)
    ts = np.where(np.isfinite(ts[ok]), ts[ok], 0.0)
    # segment ends: the grid step that receives each pseudo-measurement
    steps = step_index(t_grid_s, tp, clip=True)
    ends = np.unique(steps)
    std_of_end = {int(e): (float(s), float(d), float(x))
                  for e, s, d, x in zip(steps, sd, dd, ts)}
    cuts = [0] + [int(e) + 1 for e in ends if e + 1 < t_grid_s.size] + [t_grid_s.size]
    cuts = sorted(set(cuts))
    parts: list[EKFResult] = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        std, drift, change = std_of_end.get(b - 1, (settings.slip_std, settings.slip_std, 0.0))
        model = SkidSteerSlipModel(replace(
            settings, slip_std=std, slip_psd=settings.slip_psd + settings.slip_psd_rel
            * drift ** 2 + settings.slip_psd_transient * change ** 2))
        # a segment after the first starts one step early, at the previous segment's last
        # step and estimate (no sample of its own there): the filter predicts over that step
        # with this segment's model, and the samples of step a are those of (t_{a-1}, t_a],
        # as on the whole grid (from its own first step, a segment took those of one step of
        # its own grid: on a grid of uneven steps it counted some as outside)
        first = a - 1 if parts else a
        x0, P0 = (parts[-1].x[-1], parts[-1].P[-1]) if parts else (None, None)
        # the first segment takes the samples of the whole grid's first step (one of a
        # single step, a slip window on t_0, took those of the second before the grid)
        part = run_filter(model, t_grid_s[first:b], _own_samples(base, t_grid_s, a, b),
                          gate=gate, x0=x0, P0=P0, store_covariance=True, engine="numpy",
                          step_bounds=None if bounds is None
                          else (bounds[0][first:b], bounds[1][first:b]),
                          step_bound_movable=SPEED_BOUND_MOVABLE,
                          first_step_s=(t_grid_s[1] - t_grid_s[0]
                                        if first == 0 and t_grid_s.size > 1 else None))
        parts.append(_from_step(part, a - first))
    return _concatenate(parts)


def _speed_bounds(t_grid_s: np.ndarray, wheels: SensorSamples | None,
                  settings: SkidSteerSlipSettings) -> tuple[np.ndarray, np.ndarray] | None:
    """``step_bounds`` of :func:`~terrain.estimation.runner.run_filter` holding ``v_bx``
    within :func:`speed_bounds_m_s`, each rim widened by :data:`SPEED_BOUND_NOISE_STDS`
    times the wheel noise (None when ``settings.speed_bound_braking_slip`` is None)."""
    if settings.speed_bound_braking_slip is None:
        return None
    lo, up = speed_bounds_m_s(t_grid_s, wheels, settings.speed_bound_braking_slip,
                              settings.speed_bound_rim_margin_m_s, settings.speed_bound_hold_s)
    lower = np.full((t_grid_s.size, N_STATES), -np.inf)
    upper = np.full((t_grid_s.size, N_STATES), np.inf)
    v = STATE_NAMES.index("v_bx")
    lower[:, v], upper[:, v] = lo, up
    return lower, upper


def _own_samples(samples: Mapping[str, SensorSamples], t_grid_s: np.ndarray, a: int, b: int
                 ) -> dict[str, SensorSamples]:
    """The samples that the whole-grid filter would process at steps ``a .. b - 1``.

    :func:`~terrain.estimation.runner.run_filter` places a sample on the first step at or
    after its time and also accepts samples up to one step before its first step; on a
    segment ``[a, b)`` of the grid that would process a sample lying on step ``a - 1`` (the
    previous segment's last step, e.g. a pseudo-measurement at a window centre on the grid)
    a second time, with the next segment's variance. Each segment gets only its own samples
    (the first also those before the grid, the last those after it: counted as outside).
    """
    out = {}
    for name, smp in samples.items():
        idx = sample_steps(t_grid_s, smp.t_s)
        keep = ((idx >= a) | (a == 0)) & ((idx < b) | (b == t_grid_s.size))
        out[name] = SensorSamples(smp.t_s[keep], smp.values[keep])
    return out


def _from_step(result: EKFResult, k: int) -> EKFResult:
    """``result`` from its step ``k`` on (its counts and meta kept: the steps left out hold
    no sample)."""
    if k == 0:
        return result
    return replace(result, t_s=result.t_s[k:], x=result.x[k:], P_diag=result.P_diag[k:],
                   P=result.P[k:], y=result.y[k:], S_diag=result.S_diag[k:],
                   accepted=result.accepted[k:], nis=result.nis[k:], dof=result.dof[k:])


def _concatenate(parts: list[EKFResult]) -> EKFResult:
    first = parts[0]
    counts: dict[str, dict[str, int]] = {}
    for p in parts:
        for name, c in p.counts.items():
            agg = counts.setdefault(name, {k: 0 for k in c})
            for k, v in c.items():
                if k in ("samples", "used", "rejected", "non_finite", "superseded", "outside"):
                    agg[k] = agg.get(k, 0) + v     # each segment holds its own samples
                else:
                    agg[k] = v
    cat = np.concatenate
    meta = dict(first.meta)
    t_s = cat([p.t_s for p in parts])
    # the rate of the whole grid (a first segment of one step has no step: its rate was NaN)
    meta.update(n_steps=int(t_s.size), segments=len(parts),
                rate_hz=float(1.0 / np.median(np.diff(t_s))) if t_s.size > 1 else float("nan"))
    for key in ("step_bounds_active", "state_bounds_clipped"):
        if key in meta:
            meta[key] = int(sum(p.meta[key] for p in parts))
    return EKFResult(t_s=t_s, x=cat([p.x for p in parts]),
                     P_diag=cat([p.P_diag for p in parts]), P=cat([p.P for p in parts]),
                     y=cat([p.y for p in parts]), S_diag=cat([p.S_diag for p in parts]),
                     accepted=cat([p.accepted for p in parts]), nis=cat([p.nis for p in parts]),
                     dof=cat([p.dof for p in parts]), state_names=first.state_names,
                     measurement_names=first.measurement_names,
                     sensor_rows=first.sensor_rows, counts=counts, meta=meta)


__all__ = ["STATE_NAMES", "MEASUREMENT_NAMES", "SENSOR_ROWS", "SkidSteerSlipSettings",
           "SkidSteerSlipModel", "run_with_pseudo_slip", "speed_bounds_m_s", "rim_speed_range_m_s",
           "SPEED_BOUND_NOISE_STDS", "SPEED_BOUND_STATES", "N_MEASUREMENTS"]
