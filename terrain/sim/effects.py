"""Named, switchable effects planted into simulated runs (fixed vocabulary).

=======================  ========  ============================================================
name                     unit      meaning (value when off)
=======================  ========  ============================================================
``icr_expansion``        1         chi: skid-steer yaw rate ``(v_R - v_L) / (chi B)`` (1)
``gyro_bias``            rad/s     constant offset added to the IMU ``wz`` (0)
``wheel_lag``            s         the wheel streams at time t hold the true value at t - lag
                                   (the value at 0 while t < lag): ``pro_`` (speeds and
                                   currents) and AgriMaRo's ``omega`` and ``cur`` (0)
``turning_resistance``   A         extra current on both sides while turning:
                                   ``value * tanh(|yaw_rate| / 0.1 rad/s)`` (0)
``current_offset``       A         mean ``curR - curL`` shift: added to the right side when
                                   positive, ``|value|`` to the left when negative (0)
``grade_resistance``     A/rad     extra current on both sides ``value * |pitch|`` on slopes,
                                   ``value >= 0`` (a slope never lowers the current); only
                                   on ``slope_turn``, the others being level (0)
=======================  ========  ============================================================

With every effect off the simulator is ideal in each named respect, but for the ICR
expansion that its own physics produces: a skid-steer's wheels skid sideways in a turn, so
with ``icr_expansion`` 1 the yaw rate is already below ``(v_R - v_L) / B`` wherever the
contact model resists that skid (physics v1: chi 1.04 on ASPHALT, 2.8 for a sandy-loam spin;
physics v2, whose combined-slip tyre law and lateral soil model explain the expansion: 1.50
on ASPHALT). The planted ``icr_expansion`` moves the skid-steer's kinematic contact lines to
``chi y`` (:func:`terrain.sim.forces.contact_layout`) on top of that, so it multiplies the
yaw response only where the physics' own chi is near 1: on ASPHALT, ``random`` scenario
(seeds 31-33, 60 s; the truth stream), a planted 1.5 raises chi from 1.043 to 1.564 on v1
(x1.50) and from 1.499 to 2.006 on v2 (x1.34), because on v2 the wheels that roll along the
expanded lines also skid less sideways (``tests/audit/test_planted_sim_v2.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from types import MappingProxyType
from typing import Iterable, Mapping

from terrain.errors import ConfigError, config_numbers


@dataclass(frozen=True)
class PlantedEffect:
    """One effect the simulator can plant (a row of the table above).

    Parameters
    ----------
    unit : str
        Unit of the magnitude (``1`` = dimensionless).
    off_value : float
        Magnitude meaning "off".
    lower, upper : float
        Accepted range of the magnitude, in ``unit``.
    """

    unit: str
    off_value: float
    lower: float
    upper: float


#: name -> planted effect (read-only). Not to be confused with the audit's vocabulary
#: (:mod:`terrain.audit.effects`), which says how each effect is fitted.
PLANTED_EFFECTS: Mapping[str, PlantedEffect] = MappingProxyType({
    "icr_expansion": PlantedEffect("1", 1.0, 1.0, 20.0),
    "gyro_bias": PlantedEffect("rad/s", 0.0, -0.5, 0.5),
    "wheel_lag": PlantedEffect("s", 0.0, 0.0, 2.0),
    "turning_resistance": PlantedEffect("A", 0.0, 0.0, 50.0),
    "current_offset": PlantedEffect("A", 0.0, -20.0, 20.0),
    # >= 0: a negative value would drive the current below 0, which the magnitude sensor
    # reflects into more current (and the audit rejects k_a_per_rad <= 0 as unphysical)
    "grade_resistance": PlantedEffect("A/rad", 0.0, 0.0, 200.0),
})
EFFECT_NAMES: tuple[str, ...] = tuple(PLANTED_EFFECTS)
#: Yaw rate at which ``turning_resistance`` reaches 76 % (tanh(1)) of its value, rad/s.
TURN_RATE_SCALE_RAD_S = 0.1


@dataclass(frozen=True)
class Effects:
    """Magnitudes of the named effects (defaults = off; units and ranges in
    :data:`PLANTED_EFFECTS`).

    Parameters
    ----------
    icr_expansion : float
        chi, dimensionless, in [1, 20].
    gyro_bias : float
        Offset of the IMU ``wz``, rad/s, in [-0.5, 0.5].
    wheel_lag : float
        Lag of the wheel stream, s, in [0, 2].
    turning_resistance : float
        Extra current while turning, A, in [0, 50].
    current_offset : float
        Right-minus-left current shift, A, in [-20, 20].
    grade_resistance : float
        Extra current per rad of pitch, A/rad, in [0, 200].

    Raises
    ------
    ConfigError
        A magnitude out of its range, or not a real number (text, None, a boolean:
        :func:`parse_effects` converts ``NAME=VALUE`` text).
    """

    icr_expansion: float = 1.0
    gyro_bias: float = 0.0
    wheel_lag: float = 0.0
    turning_resistance: float = 0.0
    current_offset: float = 0.0
    grade_resistance: float = 0.0

    def __post_init__(self) -> None:
        config_numbers("Effects", **{f.name: getattr(self, f.name) for f in fields(self)})
        for f in fields(self):
            value = float(getattr(self, f.name))
            spec = PLANTED_EFFECTS[f.name]
            if not (spec.lower <= value <= spec.upper):
                raise ConfigError(f"effect {f.name}={value} out of range [{spec.lower}, "
                                  f"{spec.upper}] ({spec.unit})")

    def active(self) -> dict[str, float]:
        """Effects that are on.

        Returns
        -------
        dict
            Name -> magnitude, for every effect not at its off value.
        """
        return {f.name: float(getattr(self, f.name)) for f in fields(self)
                if float(getattr(self, f.name)) != PLANTED_EFFECTS[f.name].off_value}

    def as_dict(self) -> dict[str, float]:
        """All effects.

        Returns
        -------
        dict
            Name -> magnitude.
        """
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


def parse_effects(items: Iterable[str] | Mapping[str, float] | None) -> Effects:
    """Parse ``NAME=VALUE`` strings (or a mapping) into :class:`Effects`.

    Parameters
    ----------
    items : iterable of str, mapping or None
        ``NAME=VALUE`` strings (each name at most once), or name -> value; None = every
        effect off.

    Returns
    -------
    Effects

    Raises
    ------
    ConfigError
        Unknown name, malformed item, a name given twice, non-numeric or out-of-range value
        (a mapping's value that is a boolean, None or not one real number included), or
        one string (or bytes, or a number) instead of a sequence of items.
    """
    if items is None:
        return Effects()
    if isinstance(items, str):
        # a string is iterable too: "gyro_bias=0.1" was read letter by letter ('g' ...)
        raise ConfigError(f"parse_effects takes a sequence of NAME=VALUE items, got the "
                          f"string {items!r}; give [{items!r}]")
    if not isinstance(items, Mapping):
        try:
            iter(items)
            iterable = not isinstance(items, (bytes, bytearray))
        except TypeError:
            iterable = False
        if not iterable:
            # 5 was a bare TypeError ('int' object is not iterable)
            raise ConfigError(f"parse_effects takes a sequence of NAME=VALUE items or a "
                              f"mapping, got {type(items).__name__}")
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
        if name not in PLANTED_EFFECTS:
            raise ConfigError(f"unknown effect {name!r}; valid choices: {', '.join(EFFECT_NAMES)}")
        if name in pairs:
            raise ConfigError(f"effect {name} given twice ({name}={pairs[name]:g} and "
                              f"{name}={value}); give each effect once")
        if not isinstance(value, str):
            # a mapping's number goes to Effects as given: float() turned True into 1
            pairs[name] = value
            continue
        try:
            pairs[name] = float(value)
        except ValueError:
            raise ConfigError(f"effect {name} needs a number, got {value!r}") from None
    return Effects(**pairs)
