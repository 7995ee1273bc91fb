"""The robot side of the closed loop: slip estimator -> desired slip -> traction controller.

:class:`TractionLoop` is the controller callback of
:func:`terrain.sim.closed_loop.simulate_closed_loop`. At every call it sees only an
:class:`~terrain.sim.closed_loop.Observation` (sensor samples since its previous call and its
own low-level command), updates the vehicle's estimator, looks up the target of the current
terrain decision in the desired-slip table (:func:`~terrain.control.desired_slip.select_target`)
and steps the traction controller (:func:`~terrain.control.traction.traction_control_step`).
With ``apply=False`` it runs in shadow mode (everything computed and logged, no correction),
so an uncontrolled run is scored against the same targets and enabling logic.

The estimators (the :class:`~terrain.control.estimators.SlipEstimator` interface, one per
vehicle: :func:`~terrain.control.estimators.estimator_for`) live in
:mod:`terrain.control.estimators`.

Bus voltages for the electrical energy (:data:`BUS_VOLTAGE_V`): AgriMaRo 48 V (seed 001
ch. 3: "UuMotor hub-motor ... powered at 48V"); Husky 24 V (Clearpath Husky A200 data sheet,
24 V sealed lead-acid battery; not in the seeds).
"""

from __future__ import annotations

import math
from types import MappingProxyType
from typing import Callable, Mapping, Protocol

import numpy as np

from terrain.control.desired_slip import SlipTable, check_table, select_target
from terrain.control.estimators import (ESTIMATORS, SlipEstimator, check_callable,
                                        estimator_for)
from terrain.control.feedforward import feedforward_step, traction_acceleration_limit
from terrain.control.traction import STEADY, TractionControlConfig, TractionController
from terrain.errors import ConfigError, config_flags, config_numbers
from terrain.run import clock_slack
from terrain.sim.closed_loop import Observation
from terrain.sim.sensors import physics_step_index
from terrain.sim.simulate import Simulation, motor_currents
from terrain.slip import wheel_longitudinal_velocity
from terrain.slip.core import skid_steer_contact_lines_m
from terrain.terramechanics.calibration import steady_slip
from terrain.terramechanics.catalogue import TERRAIN_NAMES, get_terrain
from terrain.terramechanics.slip import ground_speed_from_slip
from terrain.vehicles import get_vehicle

#: DC bus voltage of each vehicle, V (sources in the module docstring).
BUS_VOLTAGE_V: Mapping[str, float] = MappingProxyType({"agrimaro": 48.0, "husky": 24.0})


#: Distance below which a run has not moved and its energies per metre are undefined (None),
#: m: a turn in place translates by round-off only (the Husky's spin on SNOW: 6e-19 m in 4 s,
#: 2.6e21 J/m). 1 mm: ASSUMED, far above round-off, far below any run that drives.
MIN_DISTANCE_M = 1e-3


class LiveTerrain(Protocol):
    """A terrain decision made on the loop's own samples (a live classifier).

    The loop hands it every :class:`~terrain.sim.closed_loop.Observation` before it reads the
    decision, so the decision at time t rests only on samples taken by t.
    """

    def update(self, obs: Observation) -> None:
        """Fold in the samples since the previous call.

        Parameters
        ----------
        obs : Observation
            Samples since the previous call.
        """
        ...

    def __call__(self, t_s: float) -> tuple:
        """The decision available at ``t_s``.

        Parameters
        ----------
        t_s : float
            Time, s.

        Returns
        -------
        tuple
            ``(label or None, confidence)``, or ``(label, confidence, t_decided_s)`` with the
            time the decision was made (s), from which the loop takes its age: decisions
            older than the table's ``max_decision_age_s`` then get the fallback.
        """
        ...


def fallback_basis(table: SlipTable) -> str | None:
    """The catalogued terrain the table's fallback traction target comes from.

    :func:`terrain.control.desired_slip.fallback_entry` takes the traction target of the
    entry with the smallest magnitude; while no terrain is decided the loop assumes that
    terrain's curve for the feed-forward limit and the slip model (the conservative case).
    Where several entries share that target (the deformable soils at the cap: SNOW,
    SANDY_LOAM, GRASS and GRAVEL all at 0.30) the one whose curve lets the robot accelerate
    least at it (:func:`~terrain.control.feedforward.traction_acceleration_limit`), then the
    first by name: the first listed gave SANDY_LOAM's 1.59 m/s^2 for a table of SANDY_LOAM
    and GRAVEL, GRAVEL's 0.56 m/s^2 for the same classes the other way round.

    Parameters
    ----------
    table : SlipTable
        Desired-slip table.

    Returns
    -------
    str or None
        Terrain name, None for a table without entries; the same whatever the order of the
        table's classes.

    Raises
    ------
    ConfigError
        ``table`` not a :class:`~terrain.control.desired_slip.SlipTable`
        (:func:`~terrain.control.desired_slip.check_table`).
    """
    check_table(table, "fallback_basis")   # None: a bare AttributeError on entries
    if not table.entries:
        return None
    least = min(abs(e.traction) for e in table.entries.values())

    def limit(entry) -> float:   # an entry not in the catalogue (a hand-built table) last
        if entry.terrain not in TERRAIN_NAMES:
            return math.inf
        return traction_acceleration_limit(get_terrain(entry.terrain), entry.traction)

    tied = [e for e in table.entries.values() if abs(e.traction) == least]
    return min(tied, key=lambda e: (limit(e), str(e.terrain))).terrain


#: Length of the feed-forward ramp's first step, s: at the loop's first call no interval has
#: elapsed, yet the reference grows by ``a_max`` times this (0.02: ASSUMED, the default 50 Hz
#: control period, whatever the loop's rate). Kept because the measured figures of
#: docs/control_validation.md rest on it (with 0 instead: husky ``random`` on SNOW, seed 1,
#: 4 s, slip RMSE 0.0774 -> 0.0780). The PID assumes nothing: its first call integrates over
#: the 1 us floor of a repeated time only (``ki e 1e-6``).
FIRST_FEEDFORWARD_STEP_S = 0.02


class TractionLoop:
    """Controller callback: estimator -> target from the table -> traction step.

    Parameters
    ----------
    config : TractionControlConfig
        Controller settings (gains, limits, ``max_input_age_s``).
    n_units : int
        Drive units (= motors here).
    estimator : SlipEstimator
        The vehicle's estimator.
    table : SlipTable
        Desired-slip table.
    terrain_decision : callable
        ``terrain_decision(t_s) -> (label or None, confidence)``: the terrain decision
        available at time ``t_s`` (s), taken as current (age 0); or
        ``(label, confidence, t_decided_s)``: the decision with the time it was made (s), its
        age ``t_s - t_decided_s`` (0 or ``max_decision_age_s`` where it lies beyond either by
        the clocks' rounding alone, :func:`terrain.run.clock_slack`) goes to
        :func:`~terrain.control.desired_slip.select_target`
        (a decision older than the table's ``max_decision_age_s``, or with the time None,
        unknown, gets the fallback).
    apply : bool
        True: return the correction; False: shadow mode (return zeros, log everything).
    accel_tau_s : float
        Time constant of a first-order low-pass on the estimated wheel accelerations before
        ``Power_state`` (eq. 8.6) classifies traction / braking / steady, s (>= 0; 0 = off).
        Without it the mode follows the acceleration the correction itself causes and the
        loop limit-cycles between traction and braking at the control rate (seen on SNOW).
    feed_forward : bool
        Also apply the feed-forward slip limit of :mod:`terrain.control.feedforward` (the
        decided terrain's largest acceleration at the traction target; no estimate of the
        slip in it), from standstill on, where the estimate is not stale; on the decided
        catalogued terrain, or while the table's fallback applies (no, a low-confidence or a
        stale decision) on the terrain the fallback's traction target comes from
        (:func:`fallback_basis`); none where the traction target is 1 (full spin: no ground
        speed limits the wheel). Where the limit binds (``engaged``) the correction applied
        is the one that slows the wheel more; elsewhere the feedback's, so a braking
        correction (which speeds a locking wheel up) is never replaced by the feed-forward's 0.
    observer : callable, optional
        ``observer(obs)``, called with every observation before the estimator and the
        terrain decision (the ``update`` of a :class:`LiveTerrain`); None: none.

    Attributes
    ----------
    log : list of dict
        One record per call (time, ``dt_s`` the interval since the previous call in s, 0 at
        the first call, estimate, controller output, decision, ``fallback`` whether the
        table's fallback targets applied). The first call integrates over
        1 us only, the floor of a repeated time (no interval has elapsed, whatever the
        loop's rate: ``ki e 1e-6`` rad/s, the traction step needs a ``dt_s > 0``); its
        derivative is 0 (no previous slip); only the feed-forward's first ramp step assumes
        :data:`FIRST_FEEDFORWARD_STEP_S`.

    Raises
    ------
    ConfigError
        ``accel_tau_s`` not a real number, or not finite and >= 0 (named); ``apply`` or
        ``feed_forward`` not a boolean (``"no"``, 0; named); ``n_units`` not an integer
        >= 1 (:class:`~terrain.control.traction.TractionController`); ``table`` not a
        :class:`~terrain.control.desired_slip.SlipTable`
        (:func:`~terrain.control.desired_slip.check_table`); ``terrain_decision`` not
        callable, ``observer`` neither callable nor None, or ``estimator`` without an
        ``update`` method (named; each failed at the first call).
    """

    def __init__(self, config: TractionControlConfig, n_units: int, estimator: SlipEstimator,
                 table: SlipTable, terrain_decision: Callable[[float], tuple],
                 apply: bool = True, accel_tau_s: float = 0.3,
                 feed_forward: bool = True,
                 observer: Callable[[Observation], None] | None = None) -> None:
        config_numbers("TractionLoop", accel_tau_s=accel_tau_s)
        # read by truthiness, apply="no" ran the controller instead of the shadow mode
        config_flags("TractionLoop", apply=apply, feed_forward=feed_forward)
        if not 0.0 <= accel_tau_s < math.inf:   # NaN fails: it turned the filter off, unsaid
            raise ConfigError(f"TractionLoop accel_tau_s must be a finite time constant >= 0 "
                              f"s (0 = no filter), got {accel_tau_s}")
        check_table(table, "TractionLoop")   # (fallback_basis read table.entries)
        if not callable(terrain_decision):
            raise ConfigError(f"TractionLoop: terrain_decision must be a function of the time, "
                              f"got {type(terrain_decision).__name__} {terrain_decision!r:.60}")
        check_callable("TractionLoop", observer=observer)
        if not callable(getattr(estimator, "update", None)):
            raise ConfigError(f"TractionLoop: estimator must be a SlipEstimator (estimator_for"
                              f"(vehicle)), got {type(estimator).__name__} {estimator!r:.60}")
        self.controller = TractionController(config, n_units)
        self.observer = observer
        self.feed_forward = bool(feed_forward)
        self.v_ref = np.zeros(n_units)
        self.ff_engaged = np.zeros(n_units, dtype=bool)
        self._accel_limit: dict[tuple[str, float], float] = {}
        self.estimator = estimator
        self.table = table
        self._fallback_basis = fallback_basis(table)
        self.terrain_decision = terrain_decision
        self.apply = bool(apply)
        self.t_prev: float | None = None
        self.accel_tau_s = float(accel_tau_s)
        self.a_filtered: np.ndarray | None = None
        self.log: list[dict] = []

    def __call__(self, obs: Observation) -> np.ndarray:
        """One control step.

        Parameters
        ----------
        obs : Observation
            Samples since the previous call.

        Returns
        -------
        ndarray, shape (n_units,)
            Wheel speed correction, rad/s (zeros in shadow mode; the traction step's safe
            output, zeros, at a call whose time went back or is not finite, and at the call
            after a non-finite one: no interval is known).

        Raises
        ------
        ConfigError
            ``terrain_decision`` returned something other than a pair ``(label or None,
            confidence)`` or a triple ``(label, confidence, t_decided_s)`` (a bare label, a
            1-tuple, None), or a decision time that is not a real number or None (text, a
            boolean).
        """
        if self.observer is not None:
            self.observer(obs)
        est = self.estimator.update(obs)
        decision = self.terrain_decision(obs.t_s)
        if isinstance(decision, (str, bytes)) or not isinstance(decision, (tuple, list)) \
                or len(decision) not in (2, 3):   # "GRASS" was label "G", confidence "R"
            raise ConfigError(f"terrain_decision({obs.t_s}) must return (label or None, "
                              "confidence) or (label, confidence, t_decided_s), got "
                              f"{type(decision).__name__} {decision!r:.60}")
        label, conf = decision[0], decision[1]
        # a decision of unknown time (stamp None) has no age: the fallback (select_target)
        stamp = decision[2] if len(decision) > 2 else obs.t_s
        config_numbers("terrain_decision", optional=("t_decided_s",), t_decided_s=stamp)
        age = None if stamp is None else self._decision_age(obs.t_s, float(stamp))
        targets = select_target(self.table, label, conf, decision_age_s=age)
        # the first call has no previous one: no interval has elapsed, so the PID integrates
        # over 1 us only (dt 0, floored to 1 us as a repeated time); only the feed-forward's first
        # ramp step keeps its ASSUMED length (FIRST_FEEDFORWARD_STEP_S, documented above)
        first = self.t_prev is None
        dt = 0.0 if first else obs.t_s - self.t_prev
        self.t_prev = obs.t_s
        # the interval the filter and the ramp move by: 0 for a time that went back or is
        # unknown (NaN: max(nan, 0.0) is nan, which stopped the feed-forward; +inf, a call
        # at or after one at +-inf, stopped it too)
        elapsed = dt if 0.0 < dt < math.inf else 0.0
        a = np.asarray(est.a_local_m_s2, dtype=float)
        if self.a_filtered is None or not np.all(np.isfinite(self.a_filtered)):
            self.a_filtered = a.copy()
        elif self.accel_tau_s > 0:   # a call back in time (dt < 0) moves the filter by 0
            self.a_filtered = self.a_filtered + (
                1 - math.exp(-elapsed / self.accel_tau_s)) * (a - self.a_filtered)
        else:
            self.a_filtered = a
        # a repeated time is floored at 1 us; a time that went back (dt < 0) is passed on:
        # the traction step's safe output, which clears the memory
        out = self.controller.step(targets, obs.omega_low_level, est.omega_meas_rad_s,
                                   est.v_long_m_s, self.a_filtered, est.chassis_speed_m_s,
                                   dt if dt < 0.0 else max(dt, 1e-6),
                                   self._estimate_age(obs.t_s, est.age_s))
        correction = out.correction_rad_s
        ff_terrain = (targets.terrain if targets.terrain in TERRAIN_NAMES
                      else self._fallback_basis)
        if self.feed_forward and ff_terrain in TERRAIN_NAMES and targets.traction >= 1.0:
            # a traction target of 1 (in a DesiredSlip's range (0, 1]) allows full spin: no
            # ground speed limits the wheel (feedforward_step refuses it), no limit binds
            self.ff_engaged = np.zeros_like(self.ff_engaged)
        elif self.feed_forward and ff_terrain in TERRAIN_NAMES:
            key = (ff_terrain, float(targets.traction))
            if key not in self._accel_limit:
                self._accel_limit[key] = traction_acceleration_limit(
                    get_terrain(ff_terrain), targets.traction)
            ff = feedforward_step(self.v_ref, est.v_long_m_s, obs.omega_low_level,
                                  self._accel_limit[key], targets.traction,
                                  self.controller.config.wheel_radius_m,
                                  FIRST_FEEDFORWARD_STEP_S if first else elapsed,
                                  self.ff_engaged)
            self.v_ref, self.ff_engaged = ff.v_ref_m_s, ff.engaged
            # the feed-forward replaces the feedback only where its limit binds (engaged) and
            # it slows the wheel more; elsewhere its correction is 0, and a "smaller |command|"
            # rule alone would discard every braking correction (those speed the wheel up)
            low = obs.omega_low_level
            use_ff = (~out.safe) & ff.engaged & (
                np.abs(low + ff.correction_rad_s) < np.abs(low + correction))
            correction = np.where(use_ff, ff.correction_rad_s, correction)
        # copies: the caller's command buffer and the estimator's arrays may be reused and
        # changed in place after this call, and the correction returned is the caller's
        self.log.append({"t_s": obs.t_s, "dt_s": dt,
                         "omega_low_level": np.array(obs.omega_low_level, dtype=float),
                         "v_long": np.array(est.v_long_m_s, dtype=float), "slip_est": out.slip,
                         "desired": out.desired_slip,
                         "steady_target": np.sign(np.asarray(est.v_long_m_s, dtype=float))
                         * float(targets.steady),
                         "enabled": out.enabled,
                         "safe": out.safe, "mode": out.mode,
                         "correction": correction, "terrain": label,
                         "decision_age_s": age, "target_traction": targets.traction,
                         "fallback": targets is self.table.fallback})
        return correction.copy() if self.apply else np.zeros_like(correction)

    def _estimate_age(self, t_s: float, age_s):
        """The estimator's ``age_s`` taken as exactly 0 or the controller's
        ``max_input_age_s`` where it lies beyond either by the clocks' rounding alone
        (:func:`terrain.run.clock_slack` at the call's time), as :meth:`_decision_age`
        reads a decision's age: on an epoch clock an estimate whose reference sample was
        taken at the call, stamped by another rounding, read -2.4e-7 s and got the safe
        output (which clears the controller's memory). Anything else (None, NaN, an age
        beyond the slack) is passed on as it is, for the traction step to judge."""
        if age_s is None or isinstance(age_s, bool) \
                or not isinstance(age_s, (int, float, np.floating, np.integer)):
            return age_s
        age = float(age_s)
        if not math.isfinite(age):
            return age_s
        return _snapped_age(age, max(abs(t_s), abs(t_s - age)),
                            self.controller.config.max_input_age_s)

    def _decision_age(self, t_s: float, t_decided_s: float) -> float:
        """``t_s - t_decided_s``, s, taken as exactly 0 or ``max_decision_age_s`` where it
        lies beyond either by the clocks' rounding alone (:func:`terrain.run.clock_slack`):
        on a 50 Hz call grid a decision 200 calls old read 4.000000000000001 s, one stamped
        at the call by another rounding a negative age, and both got the fallback."""
        return _snapped_age(t_s - t_decided_s, max(abs(t_s), abs(t_decided_s)),
                            self.table.config.max_decision_age_s)


def _snapped_age(age_s: float, t_s: float, cap_s: float) -> float:
    """An age, s, taken as exactly 0 or ``cap_s`` where it lies beyond either by no more
    than the clocks' rounding near ``t_s`` (:func:`terrain.run.clock_slack`); NaN and
    infinities are returned as they are."""
    if not math.isfinite(age_s):
        return age_s
    slack = float(clock_slack(t_s))
    if cap_s < age_s <= cap_s + slack:
        return cap_s
    return 0.0 if -slack <= age_s < 0.0 else age_s


def loop_metrics(sim: Simulation, loop: TractionLoop, bus_voltage_v: float,
                 cruise_fraction: float = 0.95, steady_after_s: float = 3.0,
                 final_window_s: float = 2.0) -> dict:
    """Scores of a closed-loop (or shadow-mode) run against the ground truth.

    Parameters
    ----------
    sim : Simulation
        The simulated run with its physics.
    loop : TractionLoop
        The loop that ran in it (its ``log``).
    bus_voltage_v : float
        DC bus voltage, V (:data:`BUS_VOLTAGE_V`).
    cruise_fraction : float
        ``time_to_speed_s``: first time the true speed reaches this fraction of the
        reference speed ``reference_speed_m_s`` (below).
    steady_after_s : float
        Steady-driving slip error counted only this long after the cruise speed is reached, s.
    final_window_s : float
        ``final_speed_m_s``: the mean true speed over the last ``final_window_s`` of the run,
        s (reported; not the reference of ``time_to_speed_s``).

    Returns
    -------
    dict
        ``cruise_speed_m_s`` (largest mean low-level wheel command times the radius),
        ``reference_speed_m_s`` (``cruise_speed_m_s (1 - s_ss)``, ``s_ss`` the largest
        :func:`terrain.terramechanics.steady_slip` of the catalogued terrains driven on: the
        speed the command holds on flat ground once the resistances balance; it depends on
        the command and the true terrain only, so a controlled run and an uncontrolled one
        are timed against the same speed; a run whose controller holds the robot below it
        never reaches it, ``time_to_speed_s`` None),
        ``final_speed_m_s``,
        ``slip_rmse`` (true slip against the signed set point of eqs. 8.7-8.9, the table's
        traction, braking or steady target by the mode, where the controller is enabled;
        with the one-sided limiter the steady mode's *limit* is the traction target, but
        the set point scored is the steady target),
        ``slip_excess_rmse`` (one-sided: RMSE of ``max(0, sgn(limit) (slip - limit))`` with
        the limit the controller enforced, the ``desired`` of the log, where enabled: only
        slip beyond the limit counts),
        ``peak_slip`` (largest |true slip| of any motor), ``peak_slip_gated`` (the same where
        the chassis speed exceeds the enabling threshold; None if it never does),
        ``time_to_speed_s`` (None if never),
        ``energy_j_per_m`` (``V_bus sum |I| dt / distance``, motor currents of the motor law
        as the run's physics version reports them,
        :func:`terrain.sim.simulate.motor_currents`; this and the two other per-metre
        energies None where the distance is below :data:`MIN_DISTANCE_M`),
        ``mech_energy_j_per_m`` (``sum max(tau omega, 0) dt / distance``),
        ``drive_energy_j_per_m`` (``sum k_t G |omega| |I| dt / distance``: what a PWM drive
        passes to the motors, :meth:`terrain.vehicles.MotorParams.drive_power_w`; the bus
        figure above ignores the duty cycle), ``distance_m``,
        ``mean_speed_m_s``, ``steady_slip_error_max`` / ``steady_slip_error_mean`` /
        ``steady_slip_within_0_02`` (|slip - the table's steady target| in steady mode,
        ``steady_after_s`` after ``time_to_speed_s``, where enabled), ``safe_fraction``,
        ``enabled_fraction``, ``speed_estimate_rmse_m_s``, ``terrain_accuracy`` (share of control
        steps whose decision
        equals the true terrain; no decision counts as wrong), ``terrain_decisions`` (control
        steps per decided class, ``NONE`` = no decision yet; a stale or low-confidence
        decision counts as its class), ``fallback_steps`` (control steps that ran on the
        table's fallback targets: no, an untrusted or a stale decision),
        ``speed_limit_clipped_steps``
        (per motor, physics steps whose low-level command was clipped at the wheel speed
        limit) and ``correction_clipped_steps`` (per motor, those whose command plus the
        controller's correction was; None for a run without a hook), from the run's
        :class:`~terrain.sim.dynamics.PhysicsResult`, and ``controller_cam_rows_dropped``
        (camera samples the controller's camera outages removed; None without a camera).
    """
    phys = sim.physics
    vehicle = get_vehicle(sim.config.vehicle)
    dt = float(phys.t_s[1] - phys.t_s[0])
    speed = np.hypot(phys.twist[:, 0], phys.twist[:, 1])
    distance = float(np.sum(speed) * dt)
    moved = distance >= MIN_DISTANCE_M     # below: round-off of a turn in place, no J/m
    duration = float(phys.t_s[-1] - phys.t_s[0] + dt)
    # the run's own physics version: v2 reports the no-load current while a motor brakes
    # (the power drawn); the v1 report of every run read 358.7 J/m for a v2 run's 281.8
    cur = motor_currents(phys, vehicle, sim.config.effects, sim.config.physics)
    energy = bus_voltage_v * float(np.sum(cur) * dt)
    drive = float(np.sum(vehicle.motor.drive_power_w(cur, phys.omega)) * dt)
    mech = float(np.sum(np.maximum(phys.torque * phys.omega, 0.0)) * dt)
    log = loop.log
    omega_ll = np.array([r["omega_low_level"] for r in log])
    cruise = float(np.max(np.abs(omega_ll).mean(axis=1))) * vehicle.wheel_radius_m
    final = float(np.mean(speed[phys.t_s >= phys.t_s[-1] - final_window_s]))
    # reference common to the controlled and uncontrolled runs: the command less the steady
    # slip of the true terrain (with steady slip the command itself is never reached)
    driven = np.asarray(phys.terrain_names)[np.unique(phys.terrain_index)]
    s_ss = max((steady_slip(get_terrain(str(n))) for n in driven
                if str(n).upper() in TERRAIN_NAMES), default=0.0)
    # the ground speed a rim at the cruise command gives at that slip (the SAE slip's one
    # inverse, eq. 7.1: omega r (1 - s) in traction)
    reference = float(ground_speed_from_slip(cruise, s_ss))
    reached = np.flatnonzero(speed >= cruise_fraction * reference) if reference > 0.05 \
        else np.array([], dtype=int)
    t_speed = float(phys.t_s[reached[0]]) if reached.size else None
    t_log = np.array([r["t_s"] for r in log])
    idx = physics_step_index(phys.t_s, t_log)
    slip_true = phys.slip_motor[idx]
    desired = np.array([r["desired"] for r in log])
    enabled = np.array([r["enabled"] for r in log])
    safe = np.array([r["safe"] for r in log])
    mode = np.array([r["mode"] for r in log])
    # set point of eqs. 8.7-8.9 (the one-sided limiter's steady limit is the traction target)
    setpoint = np.where(mode == STEADY, np.array([r["steady_target"] for r in log]), desired)
    err = (slip_true - setpoint)[enabled]
    excess = np.maximum(np.sign(desired) * (slip_true - desired), 0.0)[enabled]
    gate = speed > loop.controller.config.chassis_speed_threshold_m_s
    steady = enabled & (mode == STEADY)
    if t_speed is not None:
        steady &= (t_log >= t_speed + steady_after_s)[:, None]
    else:
        steady &= False
    s_err = np.abs(slip_true - setpoint)[steady]
    v_est = np.array([r["v_long"] for r in log])
    # each unit's true longitudinal velocity by the slip module's eqs. 7.3-7.5 (one home of
    # the relation): at the steering axes, or at a skid-steer's contact lines +-B/2
    tw = phys.twist[idx]
    if vehicle.contact_geometry().steered:
        v_true = wheel_longitudinal_velocity(tw[:, 0], tw[:, 1], tw[:, 2],
                                             np.asarray(vehicle.wheel_positions_m),
                                             phys.delta[idx])
    else:
        v_true = wheel_longitudinal_velocity(tw[:, 0], tw[:, 1], tw[:, 2],
                                             skid_steer_contact_lines_m(vehicle.track_m))
    truth_names = np.asarray(phys.terrain_names)[phys.terrain_index[idx]]
    decided = np.array([str(r["terrain"]).upper() for r in log])
    return {
        "slip_rmse": float(np.sqrt(np.mean(err ** 2))) if err.size else None,
        "slip_excess_rmse": float(np.sqrt(np.mean(excess ** 2))) if excess.size else None,
        "peak_slip": float(np.max(np.abs(phys.slip_motor))),
        "peak_slip_gated": float(np.max(np.abs(phys.slip_motor[gate]))) if gate.any() else None,
        "time_to_speed_s": t_speed,
        "cruise_speed_m_s": cruise,
        "reference_speed_m_s": reference,
        "final_speed_m_s": final,
        "energy_j_per_m": energy / distance if moved else None,
        "mech_energy_j_per_m": mech / distance if moved else None,
        "drive_energy_j_per_m": drive / distance if moved else None,
        "distance_m": distance,
        "mean_speed_m_s": distance / duration,
        "steady_slip_error_max": float(np.max(s_err)) if s_err.size else None,
        "steady_slip_error_mean": float(np.mean(s_err)) if s_err.size else None,
        "steady_slip_within_0_02": float(np.mean(s_err <= 0.02)) if s_err.size else None,
        "enabled_fraction": float(np.mean(enabled)),
        "safe_fraction": float(np.mean(safe)),
        "speed_estimate_rmse_m_s": float(np.sqrt(np.mean((v_est - v_true) ** 2))),
        "terrain_accuracy": float(np.mean(decided == truth_names)),
        "terrain_decisions": {str(k): int(v) for k, v in zip(*np.unique(decided,
                                                                        return_counts=True))},
        "fallback_steps": int(sum(bool(r.get("fallback", False)) for r in log)),
        "bus_voltage_v": bus_voltage_v,
        "speed_limit_clipped_steps": phys.speed_clipped_steps.tolist(),
        "correction_clipped_steps": (None if phys.correction_clipped_steps is None
                                     else phys.correction_clipped_steps.tolist()),
        "controller_cam_rows_dropped": sim.run.meta.get("controller_cam_rows_dropped"),
    }


#: Controller settings of the closed loop per vehicle besides the gains: estimates older than
#: ``max_input_age_s`` give the safe output. AgriMaRo: 0.5 s of camera outage (its EKF coasts
#: on IMU and slipping wheels); Husky: 1.6 encoder periods of its 6.5 Hz wheel stream.
LOOP_SETTINGS: Mapping[str, Mapping[str, float]] = MappingProxyType({
    "agrimaro": MappingProxyType({"max_input_age_s": 0.5}),
    "husky": MappingProxyType({"max_input_age_s": 0.25}),
})

#: Gains (kp rad/s per unit slip, ki rad/s per unit slip and second) of each vehicle with its
#: default estimator (the first of :data:`terrain.control.estimators.ESTIMATORS`), found by
#: the tuning of ``terrain control-grid`` on the tuning seeds, feed-forward on
#: (docs/control_validation.md; re-tuned 2026-11-26 after the integrator's torque fix and the
#: loop's anti-windup and feed-forward fixes): AgriMaRo with its EKF + VO (kp = 5, ki = 0,
#: cost 0.0963; ki = 10 0.0997); Husky with the fused slip estimate, motor currents in the
#: loop (kp = 2, ki = 0: every candidate now costs the same, 0.0905, because the feedback never
#: acts on the tuning runs: the feed-forward limit holds the slip and the estimate no longer
#: overshoots at the end of the ramp; the smallest gains are kept). The AgriMaRo's default
#: estimator reads the gyro of the full IMU since 2026-11-26 (``ekf-vo-full-gyro``); with it
#: the same search gives kp 2 and 5 within 1e-4 of each other (0.0622, 0.0623; kp 10 0.0628,
#: kp 20 0.109), so the gains stay (5, 0), now also those of ``ekf-vo``. Since the
#: simulator's implicit-step fix the Husky's candidates all cost 0.0470-0.0484 (kp 0.5-20):
#: on level ground the feed-forward does all the work and the feedback acts only on slopes
#: (``benchmarks/feedback_contribution.py``, docs/control_validation.md).
DEFAULT_GAINS: Mapping[str, tuple[float, float]] = MappingProxyType({
    "agrimaro": (5.0, 0.0), "husky": (2.0, 0.0)})

#: Gains of the non-default estimators ``(vehicle, kind) -> (kp, ki)``, same tuning: the
#: Husky's interim wheel + IMU observer (kp = 5, ki = 0, cost 0.0904; ki = 10 0.210).
ESTIMATOR_GAINS: Mapping[tuple[str, str], tuple[float, float]] = MappingProxyType({
    ("husky", "observer"): (5.0, 0.0)})


def default_gains(vehicle: str, estimator: str | None = None) -> tuple[float, float]:
    """Tuned ``(kp, ki)`` of a vehicle with an estimator kind.

    Parameters
    ----------
    vehicle : str
        ``agrimaro`` or ``husky``.
    estimator : str, optional
        Estimator kind (:data:`terrain.control.estimators.ESTIMATORS`); None: the vehicle's default.

    Returns
    -------
    tuple of float
        :data:`ESTIMATOR_GAINS` of the pair where listed, else :data:`DEFAULT_GAINS` of the
        vehicle (kp in rad/s per unit slip, ki in rad/s per unit slip and second).

    Raises
    ------
    ConfigError
        Vehicle without closed-loop gains (a list: a bare TypeError); an estimator kind
        that is not text or not one of the vehicle's (it got the default gains unsaid).
    """
    if not isinstance(vehicle, str) or vehicle not in DEFAULT_GAINS:
        raise ConfigError(f"the traction control loop supports vehicles "
                          f"{', '.join(DEFAULT_GAINS)}, got {vehicle!r}")
    # "" is the default, as for estimator_for
    if estimator is not None and not (isinstance(estimator, str) and (
            estimator == "" or estimator in ESTIMATORS[vehicle])):
        raise ConfigError(f"default_gains: estimator {estimator!r} not available for "
                          f"{vehicle}; valid: {', '.join(ESTIMATORS[vehicle])}")
    return ESTIMATOR_GAINS.get((vehicle, estimator or ""), DEFAULT_GAINS[vehicle])


def check_gains(gains, owner: str) -> tuple:
    """Refuse gains that are not a pair ``(kp, ki)`` of real numbers.

    Parameters
    ----------
    gains : object
        ``(kp, ki)``: rad/s per unit slip, rad/s per unit slip and second.
    owner : str
        Who asks, for the message (``"run_closed_loop gains"``, ``"run_grid gains['husky']"``).

    Returns
    -------
    tuple
        ``(kp, ki)`` as given (their range is
        :class:`~terrain.control.traction.TractionControlConfig`'s to check).

    Raises
    ------
    ConfigError
        Not a pair (one number, text, a ``(kp, ki, kd)`` triple), or a gain that is not a
        real number (text, ``None``, a boolean; named ``owner.kp``).
    """
    if isinstance(gains, (str, bytes)) or not hasattr(gains, "__len__") or len(gains) != 2:
        raise ConfigError(f"{owner}: gains must be a pair (kp, ki) of numbers, rad/s per unit "
                          f"slip and rad/s per unit slip and second, got {gains!r:.60}")
    kp, ki = gains
    config_numbers(owner, kp=kp, ki=ki)
    return kp, ki


def run_closed_loop(vehicle: str, terrain: str, scenario: str, controller_on: bool, seed: int,
                    duration_s: float = 20.0, gains: tuple[float, float] | None = None,
                    table: SlipTable | None = None,
                    terrain_decision: Callable[[float], tuple] | None = None,
                    estimator: str | None = None, feed_forward: bool = True,
                    live_terrain: LiveTerrain | None = None
                    ) -> tuple[Simulation, TractionLoop, dict]:
    """Simulate one closed-loop run and score it.

    Parameters
    ----------
    vehicle : str
        ``agrimaro`` or ``husky``.
    terrain : str
        Catalogued terrain class of the whole run.
    scenario : str
        Simulator scenario (``straight_accel``, ``orchard``, ``slope_turn``...).
    controller_on : bool
        True: traction control applied; False: shadow mode (no correction).
    seed : int
        Run seed (>= 0).
    duration_s : float
        Simulated time, s.
    gains : tuple of float, optional
        ``(kp, ki)``; None: :func:`default_gains` of the vehicle and estimator.
    table : SlipTable, optional
        Desired-slip table; None: built for ``terrain`` alone.
    terrain_decision : callable, optional
        ``f(t_s) -> (label or None, confidence)`` or ``(label, confidence, t_decided_s)``
        (:class:`TractionLoop`); None: the run's terrain label with confidence 1 (the ground
        truth: see the pipelines for when this applies). While it gives no label the
        estimator's slip model assumes the :func:`fallback_basis` terrain.
    estimator : str, optional
        Estimator kind (:func:`terrain.control.estimators.estimator_for`); None: the vehicle's
        default.
    feed_forward : bool
        Feed-forward slip limit in the loop (:class:`TractionLoop`).
    live_terrain : LiveTerrain, optional
        A live classifier fed with the loop's own observations (its ``update`` is the loop's
        observer) whose decisions are used instead of ``terrain_decision``; a fresh one per
        run (it keeps the run's samples).

    Returns
    -------
    sim : Simulation
    loop : TractionLoop
    metrics : dict
        :func:`loop_metrics` plus the estimator's name and limits, and its counts where it
        keeps them (None otherwise): pseudo-measurements used, samples the speed bound
        projected, samples skipped for a NaN or infinite value
        (``estimator_nonfinite_samples``).

    Raises
    ------
    ConfigError
        Unknown vehicle, terrain or scenario, bad gains (not a pair of real numbers, named,
        or refused by :class:`~terrain.control.traction.TractionControlConfig`),
        ``controller_on`` or ``feed_forward`` not a boolean (:class:`TractionLoop`), or both
        ``terrain_decision`` and ``live_terrain`` given.
    """
    from terrain.control.desired_slip import build_slip_table
    from terrain.control.traction import config_for_vehicle
    from terrain.sim.closed_loop import simulate_closed_loop
    from terrain.sim.simulate import SimConfig

    if vehicle not in LOOP_SETTINGS:
        raise ConfigError(f"the traction control loop supports vehicles agrimaro and husky, "
                          f"got {vehicle!r}")
    gains = default_gains(vehicle, estimator) if gains is None else gains
    kp, ki = check_gains(gains, "run_closed_loop gains")
    cfg, n = config_for_vehicle(vehicle, kp=float(kp), ki=float(ki), **LOOP_SETTINGS[vehicle])
    if live_terrain is not None and terrain_decision is not None:
        raise ConfigError("give terrain_decision or live_terrain, not both")
    table = table or build_slip_table([terrain])
    decision = live_terrain or terrain_decision or (lambda t: (terrain, 1.0))
    basis = fallback_basis(table)

    def assumed(t_s: float) -> tuple:   # the estimator's slip model: undecided -> basis
        label, conf = decision(t_s)[:2]
        return (label, conf) if label is not None else (basis, 0.0)

    estimator = estimator_for(vehicle, assumed, estimator)
    loop = TractionLoop(cfg, n, estimator, table, decision, apply=controller_on,
                        feed_forward=feed_forward,
                        observer=None if live_terrain is None else live_terrain.update)
    sim = simulate_closed_loop(SimConfig(vehicle=vehicle, terrains=(terrain,),
                                         scenario=scenario, duration_s=duration_s,
                                         seed=seed), loop)
    metrics = loop_metrics(sim, loop, BUS_VOLTAGE_V[vehicle])
    metrics.update(estimator=estimator.name, estimator_limits=estimator.limits,
                   estimator_pseudo_measurements=getattr(estimator, "pseudo_count", None),
                   estimator_speed_bound_samples=getattr(estimator, "bound_count", None),
                   estimator_nonfinite_samples=getattr(estimator, "nonfinite_count", None),
                   kp=float(kp), ki=float(ki), feed_forward=bool(feed_forward))
    return sim, loop, metrics


def trace_frame(sim: Simulation, loop: TractionLoop):
    """Per-call trace of a closed-loop run: truth next to what the controller saw and did.

    Parameters
    ----------
    sim : Simulation
        The closed-loop (or shadow-mode) run with its physics.
    loop : TractionLoop
        The loop that ran in it (its ``log``, one record per control call).

    Returns
    -------
    pandas.DataFrame
        ``t_s, v_true_m_s``, then per unit ``slip_true_i, slip_est_i, target_i,
        correction_i`` (dimensionless, rad/s), ``enabled_i, safe_i``, and ``terrain``.
    """
    import pandas as pd

    phys = sim.physics
    t = np.array([r["t_s"] for r in loop.log])
    idx = physics_step_index(phys.t_s, t)
    cols = {"t_s": t, "v_true_m_s": phys.twist[idx, 0]}
    for i in range(phys.slip_motor.shape[1]):
        cols[f"slip_true_{i + 1}"] = phys.slip_motor[idx, i]
        for key, name in (("slip_est", "slip_est"), ("desired", "target"),
                          ("correction", "correction"), ("enabled", "enabled"),
                          ("safe", "safe")):
            cols[f"{name}_{i + 1}"] = [r[key][i] for r in loop.log]
    cols["terrain"] = [r["terrain"] for r in loop.log]
    return pd.DataFrame(cols)
