"""Driving scenarios: body-twist commands over time (seeded, reproducible).

Each scenario returns a :class:`Commands` with the commanded twist ``(v_x, v_y, yaw_rate)``
at the physics rate and the inclination of the ground plane.

``straight_accel``  seed 001 ch. 7.2.3: accelerate at 1 m/s^2 to 1 m/s, then cruise.
``orchard``         seed 000 sec. III: rows at constant speed, U-turns at the headland with
                    constant speed and turning radius (1.5 m), alternating left/right; the
                    speed leaves a skid-steer's outer side within the speed limit in the turn.
``slope_turn``      seed 003 Experiment III: turning at 20 deg/s (the direction reversing every
                    20 s) on a 15 deg slope (the plane rises along world +x), at 0.2 m/s and
                    the seed's 0.05 m/s alternately, 10 s each (0.2 m/s first). The seed drove
                    at 5 cm/s only: the 0.2 m/s segments are ASSUMED, not from the seed.
``spin``            spin in place at 0.6 rad/s, reversing every 8 s.
``random``          piecewise-constant random commands (2-6 s segments), acceleration-limited.

Every command but ``straight_accel``'s ramp (which is 0 at t = 0 by itself) is rate-limited
from rest: the vehicle starts standing, and the command at t = 0 is one rate-limited step from
0 (the limiter steps before the first sample: ``orchard`` 0.005 m/s and ``spin`` 0.015 rad/s
at 100 Hz; ``tests/sim/test_scenarios.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping

import numpy as np

from terrain.errors import ConfigError, config_flags, config_positive

SCENARIO_NAMES: tuple[str, ...] = ("straight_accel", "orchard", "slope_turn", "spin", "random")
#: Inclination of each scenario's ground plane (rising along world +x), rad (read-only):
#: ``slope_turn``'s 15 deg slope (seed 003 Experiment III); the others are level.
SCENARIO_SLOPES_RAD: Mapping[str, float] = MappingProxyType(
    {name: float(np.radians(15.0)) if name == "slope_turn" else 0.0 for name in SCENARIO_NAMES})


@dataclass(frozen=True)
class Commands:
    """Commanded motion.

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Time, s.
    twist : ndarray, shape (n, 3)
        Commanded ``(v_x, v_y, yaw_rate)`` in the body frame, m/s, m/s, rad/s.
    slope_rad : float
        Inclination of the ground plane (rises along world +x), rad.
    """

    t_s: np.ndarray
    twist: np.ndarray
    slope_rad: float = 0.0


def _rate_limit(x: np.ndarray, max_rate: float, dt: float) -> np.ndarray:
    """``x`` followed at no more than ``max_rate`` per second, starting from rest (0).

    Every scenario starts with the vehicle at rest, so the limited command starts at 0 too
    (it started at ``x[0]``: a step to the first segment's speed at t = 0, e.g. 0.5 m/s for
    ``orchard``, 0.6 rad/s for ``spin``).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Command before limiting, one sample per physics step (unit u).
    max_rate : float
        Largest change per second, u/s.
    dt : float
        Physics step, s.

    Returns
    -------
    ndarray, shape (n,)
        Limited command, u; ``out[0]`` is 0 or within ``max_rate dt`` of it.
    """
    out = np.empty_like(x)
    acc = 0.0
    step = max_rate * dt
    for i, target in enumerate(x):
        acc += min(max(target - acc, -step), step)
        out[i] = acc
    return out


def physics_steps(duration_s: float, dt_s: float) -> int:
    """Whole physics steps of a simulated duration (the time grid has one sample more).

    Parameters
    ----------
    duration_s : float
        Simulated time, s.
    dt_s : float
        Physics step, s.

    Returns
    -------
    int
        ``round(duration_s / dt_s)``: a duration that is not a whole number of steps ends
        at the nearest step (1.004 s at 100 Hz: 100 steps, the grid's last time 1.0 s;
        1.006 s: 101 steps, 1.01 s), a duration exactly half-way between two steps at the
        even count (Python's ``round``: 10.5 steps of 1/64 s give 10, 11.5 give 12).
    """
    return int(round(float(duration_s) / float(dt_s)))


def make_commands(name: str, duration_s: float, dt_s: float, rng: np.random.Generator,
                  max_speed_m_s: float, omnidirectional: bool = False,
                  track_m: float = 0.0) -> Commands:
    """Commanded twist of a named scenario.

    Parameters
    ----------
    name : str
        One of :data:`SCENARIO_NAMES`.
    duration_s : float
        > 0, s.
    dt_s : float
        Physics step, s.
    rng : numpy.random.Generator
        Randomness of ``random`` (others are deterministic and draw nothing: any value,
        None included, is fine for them).
    max_speed_m_s : float
        Vehicle speed limit, m/s. ``straight_accel``, ``orchard`` and ``slope_turn`` cap their
        speed at 0.95 of it; ``random`` draws ``v_x`` in ``[-0.3, 1]`` and ``v_y`` in
        ``[-0.5, 0.5]`` times 0.95 of it, each component within 0.95 of the limit, but not
        their resultant: an omnidirectional run's body speed ``hypot(v_x, v_y)`` reaches up
        to ``0.95 sqrt(1.25) = 1.06`` times the limit (1.008 with seed 2 over 120 s); ``spin``
        commands no speed.
    omnidirectional : bool
        Whether lateral velocity commands are allowed (swerve drive).
    track_m : float
        Track of a skid-steered vehicle, m (0: steered). In a turn of radius ``R`` at speed
        ``v`` its outer side runs at ``v (1 + track / (2 R))``; ``orchard`` lowers its speed
        so that this stays within ``0.95 max_speed_m_s`` (a clipped outer side would widen
        the U-turn and turn it by less than pi).

    Returns
    -------
    Commands

    Raises
    ------
    ConfigError
        Unknown scenario, a physics step or a duration that is not a finite time > 0, a
        duration that rounds to less than one physics step, a speed limit that is not
        finite and > 0, a track that is not finite and >= 0, ``omnidirectional`` not
        ``True`` or ``False``, or ``random`` without a :class:`numpy.random.Generator`.
    """
    if name not in SCENARIO_NAMES:
        raise ConfigError(f"unknown scenario {name!r}; valid choices: {', '.join(SCENARIO_NAMES)}")
    config_positive("make_commands", dt_s=dt_s, duration_s=duration_s,
                    max_speed_m_s=max_speed_m_s)
    config_positive("make_commands", allow_zero=True, track_m=track_m)
    # 'no' was truthy: lateral commands for a skid-steer, refused later as a v_y command
    config_flags("make_commands", omnidirectional=omnidirectional)
    if name == "random" and not isinstance(rng, np.random.Generator):
        # None or a seed was an AttributeError ('NoneType' object has no attribute 'uniform')
        raise ConfigError(f"make_commands.rng must be a numpy.random.Generator for the "
                          f"random scenario (np.random.default_rng(seed)), got "
                          f"{type(rng).__name__}")
    n = physics_steps(duration_s, dt_s) + 1
    if n < 2:
        raise ConfigError(f"duration {duration_s} s is shorter than one physics step "
                          f"({dt_s:g} s)")
    t = np.arange(n) * dt_s
    tw = np.zeros((n, 3))
    slope = SCENARIO_SLOPES_RAD[name]
    vmax = 0.95 * max_speed_m_s
    if name == "straight_accel":
        v = min(1.0, vmax)
        tw[:, 0] = np.minimum(t * 1.0, v)
    elif name == "orchard":
        row_m, radius_m = 20.0, 1.5
        v = min(0.5, vmax / (1.0 + float(track_m) / (2.0 * radius_m)))
        t_row, t_turn = row_m / v, np.pi * radius_m / v
        phase = t % (t_row + t_turn)
        k = (t // (t_row + t_turn)).astype(int)
        turning = phase >= t_row
        tw[:, 0] = v
        tw[:, 2] = np.where(turning, np.where(k % 2 == 0, 1.0, -1.0) * v / radius_m, 0.0)
        tw[:, 0] = _rate_limit(tw[:, 0], 0.5, dt_s) if n > 1 else tw[:, 0]
        tw[:, 2] = _rate_limit(tw[:, 2], 2.0, dt_s)
    elif name == "slope_turn":
        v = min(0.2, vmax)
        # the slow segment capped too (0.05 m/s ran above a limit under 0.053 m/s)
        tw[:, 0] = np.where((t // 10.0) % 2 == 0, v, min(0.05, v))
        tw[:, 2] = np.radians(20.0) * np.where((t // 20.0) % 2 == 0, 1.0, -1.0)
        tw[:, 0] = _rate_limit(tw[:, 0], 0.5, dt_s)
        tw[:, 2] = _rate_limit(tw[:, 2], 1.0, dt_s)
    elif name == "spin":
        tw[:, 2] = _rate_limit(0.6 * np.where((t // 8.0) % 2 == 0, 1.0, -1.0), 1.5, dt_s)
    else:  # random
        seg_t, seg = [], []
        now = 0.0
        while now < duration_s:
            seg_t.append(now)
            vx = rng.uniform(-0.3, 1.0) * vmax
            vy = rng.uniform(-0.5, 0.5) * vmax if omnidirectional else 0.0
            wz = rng.uniform(-0.8, 0.8) if rng.random() < 0.6 else 0.0
            seg.append((vx, vy, wz))
            now += rng.uniform(2.0, 6.0)
        idx = np.searchsorted(np.asarray(seg_t), t, side="right") - 1
        raw = np.asarray(seg)[idx]
        tw[:, 0] = _rate_limit(raw[:, 0], 0.8, dt_s)
        tw[:, 1] = _rate_limit(raw[:, 1], 0.8, dt_s)
        tw[:, 2] = _rate_limit(raw[:, 2], 1.5, dt_s)
    return Commands(t, tw, float(slope))
