"""Named, switchable effects planted into simulated runs (fixed vocabulary).

=======================  ========  ============================================================
name                     unit      meaning (value when off)
=======================  ========  ============================================================
``icr_expansion``        1         chi: skid-steer yaw rate ``(v_R - v_L) / (chi B)`` (1)
``gyro_bias``            rad/s     constant offset added to the IMU ``wz`` (0)
``wheel_lag``            s         the ``pro_`` stream at time t holds the true value at t - lag
                                   (both speeds and currents) (0)
``turning_resistance``   A         extra current on both sides while turning:
                                   ``value * tanh(|yaw_rate| / 0.1 rad/s)`` (0)
``current_offset``       A         mean ``curR - curL`` shift: added to the right side when
                                   positive, ``|value|`` to the left when negative (0)
``grade_resistance``     A/rad     extra current on both sides ``value * |pitch|`` on slopes (0)
=======================  ========  ============================================================

With every effect off the simulator is ideal in each named respect.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Iterable, Mapping

from terrain.errors import ConfigError

#: name -> (unit, value when off, lower bound, upper bound)
EFFECTS: Mapping[str, tuple[str, float, float, float]] = {
    "icr_expansion": ("1", 1.0, 1.0, 20.0),
    "gyro_bias": ("rad/s", 0.0, -0.5, 0.5),
    "wheel_lag": ("s", 0.0, 0.0, 2.0),
    "turning_resistance": ("A", 0.0, 0.0, 50.0),
    "current_offset": ("A", 0.0, -20.0, 20.0),
    "grade_resistance": ("A/rad", 0.0, -200.0, 200.0),
}
EFFECT_NAMES: tuple[str, ...] = tuple(EFFECTS)
#: Yaw rate at which ``turning_resistance`` reaches 76 % (tanh(1)) of its value, rad/s.
TURN_RATE_SCALE_RAD_S = 0.1


@dataclass(frozen=True)
class Effects:
    """Magnitudes of the named effects (defaults = off)."""

    icr_expansion: float = 1.0
    gyro_bias: float = 0.0
    wheel_lag: float = 0.0
    turning_resistance: float = 0.0
    current_offset: float = 0.0
    grade_resistance: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = float(getattr(self, f.name))
            _, _, lo, hi = EFFECTS[f.name]
            if not (lo <= value <= hi):
                raise ConfigError(f"effect {f.name}={value} out of range [{lo}, {hi}] "
                                  f"({EFFECTS[f.name][0]})")

    def active(self) -> dict[str, float]:
        """Effects that are on, name -> magnitude."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)
                if float(getattr(self, f.name)) != EFFECTS[f.name][1]}

    def as_dict(self) -> dict[str, float]:
        """All effects, name -> magnitude."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


def parse_effects(items: Iterable[str] | Mapping[str, float] | None) -> Effects:
    """Parse ``NAME=VALUE`` strings (or a mapping) into :class:`Effects`.

    Parameters
    ----------
    items : iterable of str, mapping or None

    Returns
    -------
    Effects

    Raises
    ------
    ConfigError
        Unknown name, malformed item, non-numeric or out-of-range value.
    """
    if items is None:
        return Effects()
    pairs: dict[str, float] = {}
    source = items.items() if isinstance(items, Mapping) else None
    if source is None:
        source = []
        for item in items:
            if "=" not in str(item):
                raise ConfigError(f"effect {item!r} is not NAME=VALUE; valid names: "
                                  f"{', '.join(EFFECT_NAMES)}")
            name, value = str(item).split("=", 1)
            source.append((name.strip(), value.strip()))
    for name, value in source:
        if name not in EFFECTS:
            raise ConfigError(f"unknown effect {name!r}; valid choices: {', '.join(EFFECT_NAMES)}")
        try:
            pairs[name] = float(value)
        except (TypeError, ValueError):
            raise ConfigError(f"effect {name} needs a number, got {value!r}") from None
    return Effects(**pairs)
