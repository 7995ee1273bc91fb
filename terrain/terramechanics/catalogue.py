"""Terrain catalogue: one frozen, sourced parameter set per terrain class.

Each :class:`TerrainParams` has

* a longitudinal traction-slip curve (:mod:`terrain.terramechanics.traction`);
* ``soil_resistance``: motion resistance of the ground itself (compaction, bulldozing) over
  normal load. The wheels must *push* against it, so it costs slip;
* ``hysteresis``: rolling loss that costs motor torque but no slip (tyre hysteresis, drive
  train and wheel scrub losses). It is calibrated so that the Husky's simulated straight-line
  current equals the mean measured on that terrain (:mod:`terrain.terramechanics.calibration`);
* ``lateral_friction``: lateral resistance coefficient of a skidding wheel (friction plus
  bulldozing of sunk wheels), which sets skid-steer turning resistance;
* vibration levels measured on the Husky runs (std of accelerometer / roll-pitch gyro while
  driving, at the reference speed given).

Where no published parameter set exists, ``source`` states the analogy used.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Mapping

from terrain.errors import ConfigError, config_positive
from terrain.terramechanics.resistance import G_M_S2
from terrain.terramechanics.traction import (BrixiusCurve, BurckhardtCurve, JanosiCurve,
                                             TractionCurve, brixius_mobility_number)


@dataclass(frozen=True)
class TerrainParams:
    """Parameters of one terrain class.

    Parameters
    ----------
    name : str
        Upper-case class label (``ASPHALT``...).
    curve : TractionCurve
        Gross traction coefficient vs slip.
    soil_resistance : float
        Slip-producing motion resistance coefficient (ignored for Brixius curves, which carry
        their own, see :func:`~terrain.terramechanics.resistance.soil_resistance_coefficient`).
    hysteresis : float
        Torque-only rolling-loss coefficient (dimensionless, x normal load x wheel radius).
    lateral_friction : float
        Lateral resistance coefficient of a skidding contact.
    vib_accel_m_s2 : float
        Std of the accelerometer vibration while driving at ``vib_speed_m_s``, m/s^2.
    vib_gyro_rad_s : float
        Std of the roll/pitch-rate vibration at ``vib_speed_m_s``, rad/s.
    vib_speed_m_s : float
        Speed at which the vibration levels were measured, m/s (levels scale with
        ``sqrt(v / vib_speed_m_s)``).
    source : str
        Where every number comes from.
    """

    name: str
    curve: TractionCurve
    soil_resistance: float
    hysteresis: float
    lateral_friction: float
    vib_accel_m_s2: float
    vib_gyro_rad_s: float
    vib_speed_m_s: float
    source: str

    def __post_init__(self) -> None:
        """Refuse impossible values (:class:`~terrain.errors.ConfigError` naming the field):
        soil resistance, hysteresis, lateral friction and vibration levels finite and >= 0,
        the vibration reference speed finite and > 0, and a curve with a ``coefficients``
        method (a :class:`~terrain.terramechanics.traction.TractionCurve`; anything else
        failed at its first use with an AttributeError naming no field), and a name that is
        a non-empty upper-case label without surrounding blanks (the simulator finds a
        terrain's physics-v2 soil and tyre friction factor by that name: ``snow`` ran without
        its soil, on the Coulomb lateral law)."""
        name = self.name
        if not (isinstance(name, str) and name and name == name.upper().strip()):
            raise ConfigError(f"TerrainParams.name must be an upper-case terrain label "
                              f"(ASPHALT, SNOW...), got {name!r:.60}")
        if not callable(getattr(self.curve, "coefficients", None)):
            raise ConfigError(f"TerrainParams.curve must be a traction curve (BurckhardtCurve, "
                              f"JanosiCurve, BrixiusCurve...), got {self.curve!r}")
        config_positive("TerrainParams", allow_zero=True, soil_resistance=self.soil_resistance,
                        hysteresis=self.hysteresis, lateral_friction=self.lateral_friction,
                        vib_accel_m_s2=self.vib_accel_m_s2, vib_gyro_rad_s=self.vib_gyro_rad_s)
        config_positive("TerrainParams", vib_speed_m_s=self.vib_speed_m_s)


#: Mean motor current per side measured while the Husky drives straight (A), and the mean
#: straight-line speed of those samples (m/s): borealtc and vulpi runs of ../shared/data
#: (|v| > 0.1 m/s, |v_R - v_L| < 0.05 m/s).
MEASURED_HUSKY_STRAIGHT: Mapping[str, tuple[float, float]] = MappingProxyType({
    "ASPHALT": (1.9, 0.67), "FLOORING": (1.9, 0.20), "ICE": (2.5, 0.21),
    "SANDY_LOAM": (3.9, 0.45), "SNOW": (5.2, 0.37), "CONCRETE": (3.1, 0.50),
    "DIRT_ROAD": (2.8, 0.50), "PLOUGHED": (4.7, 0.50), "UNPLOUGHED": (3.1, 0.50),
})

#: Husky reference contact used to turn soil parameters into curves: 13 in tyre, 0.11 m
#: section width, quarter of 50 kg (see terrain.vehicles.skid_steer.HuskyParams).
_HUSKY_WHEEL_LOAD_N = 50.0 * G_M_S2 / 4.0
_HUSKY_TYRE: Mapping[str, float] = MappingProxyType(
    dict(section_width_m=0.11, diameter_m=0.33, load_n=_HUSKY_WHEEL_LOAD_N))

_BURCKHARDT = "Burckhardt (1993) coefficients, as tabulated in Kiencke & Nielsen (2005)"
_BRIXIUS = ("Brixius (1987) traction equations with Bn for the Husky tyre "
            "(b = 0.11 m, d = 0.33 m, W = 123 N, delta/h = 0.1)")
_VIB = "vibration: std measured on the {} runs of ../shared/data"
_LAT_PAVED = ("lateral_friction ASSUMED 0.5: sideways sliding of rubber on dry pavement at low "
              "speed, below the longitudinal peak")


def _entries() -> dict[str, TerrainParams]:
    """Terrain parameters before the Husky current calibration (``hysteresis`` = 0)."""
    t = {}

    def add(name, curve, soil, lat, vib, source, hyst=0.0):
        t[name] = TerrainParams(name, curve, soil, hyst, lat, vib[0], vib[1], vib[2], source)

    add("ASPHALT", BurckhardtCurve(1.2801, 23.99, 0.52, f"dry asphalt, {_BURCKHARDT}"),
        0.0, 0.5, (1.59, 0.038, 0.45),
        f"{_BURCKHARDT} (dry asphalt); rigid: no soil resistance; {_LAT_PAVED}; "
        + _VIB.format("borealtc ASPHALT"))
    add("CONCRETE", BurckhardtCurve(1.1973, 25.168, 0.5373, f"dry concrete, {_BURCKHARDT}"),
        0.0, 0.5, (0.46, 0.039, 0.50),
        f"{_BURCKHARDT} (dry concrete); rigid; {_LAT_PAVED}; " + _VIB.format("vulpi CONCRETE"))
    add("FLOORING", BurckhardtCurve(0.857, 33.822, 0.347, f"wet asphalt, {_BURCKHARDT}"),
        0.0, 0.45, (0.84, 0.017, 0.22),
        "no published set for indoor vinyl/linoleum flooring: ANALOGY with Burckhardt's wet "
        "asphalt (smooth sealed surface, peak mu about 0.8); lateral_friction ASSUMED 0.45; "
        + _VIB.format("borealtc FLOORING"))
    add("TILES", BurckhardtCurve(1.2801, 23.99, 0.52, f"dry asphalt, {_BURCKHARDT}"),
        0.0, 0.5, (0.84, 0.017, 0.22),
        "ANALOGY with Burckhardt's dry asphalt: seed 001 ch. 7.2.3 states tiled pavement is "
        "'highly representative of the dynamic behaviour observed on asphalt'; hysteresis "
        "0.015 ASSUMED (tyre on hard surface, Wong Theory of Ground Vehicles ch. 1.2 range "
        "0.01-0.02); vibration ANALOGY with FLOORING", hyst=0.015)
    add("ICE", BurckhardtCurve(0.05, 306.39, 0.0, f"ice, {_BURCKHARDT}"),
        0.0, 0.05, (0.86, 0.016, 0.28),
        f"{_BURCKHARDT} (ice); lateral_friction = Burckhardt ice level 0.05; "
        + _VIB.format("borealtc ICE"))
    add("PACKED_SNOW", BurckhardtCurve(0.1946, 94.129, 0.0646, f"snow, {_BURCKHARDT}"),
        0.0, 0.19, (0.86, 0.016, 0.28),
        f"{_BURCKHARDT} (snow-covered road); hysteresis 0.03 ASSUMED; lateral friction = "
        "Burckhardt peak; vibration ANALOGY with ICE", hyst=0.03)
    add("SNOW", JanosiCurve.from_soil(1030.0, 19.7, 0.04, 0.11 * 0.12, 0.12,
                                      _HUSKY_WHEEL_LOAD_N, "Wong snow (U.S.)"),
        0.10, 0.8, (2.76, 0.088, 0.23),
        "deep forest snow of borealtc is deformable: Janosi-Hanamoto with Mohr-Coulomb c = "
        "1.03 kPa, phi = 19.7 deg (snow, U.S., Wong Theory of Ground Vehicles Table 2.3, from "
        "Bekker) on a 0.11 x 0.12 m Husky contact; K = 0.04 m ASSUMED; soil_resistance 0.10 "
        "ASSUMED (compaction of fresh snow); lateral_friction 0.8 ASSUMED (bulldozing of the "
        "sunk wheels), chosen so the Husky digs in when turning, as the measured runs show "
        "(yaw rate about 6x below the kinematic one); " + _VIB.format("borealtc SNOW"))
    add("SANDY_LOAM", JanosiCurve.from_soil(1720.0, 29.0, 0.025, 0.11 * 0.08, 0.08,
                                            _HUSKY_WHEEL_LOAD_N, "Wong sandy loam"),
        0.08, 0.35, (1.23, 0.076, 0.24),
        "Janosi-Hanamoto with c = 1.72 kPa, phi = 29 deg (sandy loam, LLL, Wong Table 2.3); "
        "K = 0.025 m ASSUMED (Wong: 1-2.5 cm for firm sandy soils); soil_resistance 0.08 = "
        "tyre on medium-hard soil (Wong ch. 1.2); lateral_friction 0.35 ASSUMED (the measured "
        "Husky runs turn on this soil, chi about 1.7); "
        + _VIB.format("borealtc SANDY_LOAM"))
    add("DIRT_ROAD", BrixiusCurve(brixius_mobility_number(1.5e6, **_HUSKY_TYRE)),
        0.0, 0.55, (0.60, 0.053, 0.50),
        f"{_BRIXIUS}, cone index 1.5 MPa ASSUMED for a compacted dirt road; "
        "lateral_friction 0.55 ASSUMED; " + _VIB.format("vulpi DIRT_ROAD"))
    add("UNPLOUGHED", BrixiusCurve(brixius_mobility_number(0.8e6, **_HUSKY_TYRE)),
        0.0, 0.6, (0.53, 0.055, 0.50),
        f"{_BRIXIUS}, cone index 0.8 MPa ASSUMED for an untilled field; lateral_friction 0.6 "
        "ASSUMED; " + _VIB.format("vulpi UNPLOUGHED"))
    add("PLOUGHED", BrixiusCurve(brixius_mobility_number(0.1e6, **_HUSKY_TYRE)),
        0.0, 1.0, (0.52, 0.079, 0.50),
        f"{_BRIXIUS}, cone index 0.1 MPa ASSUMED for freshly tilled soil; lateral_friction 1.0 "
        "ASSUMED (bulldozing of sunk wheels; with it the physics-v1 Husky digs in when "
        "turning, chi 9-10, while the measured vulpi PLOUGHED curves turn with chi 2.3-2.7: "
        "physics v2 replaces this law by the soil entry "
        "terrain.terramechanics.lateral.SOILS['PLOUGHED'], docs/physics_v2.md); "
        + _VIB.format("vulpi PLOUGHED"))
    add("GRASS", JanosiCurve(0.531, 0.373, "calibrated to seed 001 ch. 7.2.3"),
        0.08, 0.6, (0.53, 0.055, 0.50),
        "no published shear parameters for the thesis's damp grass: Janosi-Hanamoto form with "
        "mu_max and K/L CALIBRATED so that AgriMaRo's steady slip at 1 m/s is 0.1255 (thesis "
        "range 0.116-0.135) and the quasi-static slip at 1 m/s^2 is 0.339 (thesis peak), with "
        "soil_resistance 0.08 (tyre on medium-hard soil, Wong ch. 1.2), see "
        "terrain.terramechanics.calibration.calibrate_janosi; hysteresis 0.015 ASSUMED; "
        "vibration ANALOGY with UNPLOUGHED", hyst=0.015)
    add("GRAVEL", JanosiCurve(0.366, 0.363, "calibrated to seed 001 ch. 7.2.3"),
        0.06, 0.55, (0.60, 0.053, 0.50),
        "firm soil with loose gravel (seed 001 ch. 7.2.3): no published set; Janosi-Hanamoto "
        "form CALIBRATED to steady slip 0.134 (thesis 0.122-0.146) and quasi-static slip 0.475 "
        "at 1 m/s^2 (thesis peak), soil_resistance 0.06 ASSUMED (loose top layer on firm "
        "ground); hysteresis 0.015 ASSUMED; vibration ANALOGY with DIRT_ROAD", hyst=0.015)
    return t


def _build() -> Mapping[str, TerrainParams]:
    from terrain.terramechanics.calibration import husky_hysteresis_for_current

    table = _entries()
    for name, (current_a, speed_m_s) in MEASURED_HUSKY_STRAIGHT.items():
        hyst = husky_hysteresis_for_current(table[name], current_a, speed_m_s)
        base = table[name]
        table[name] = replace(base, hysteresis=hyst, source=base.source + (
            f"; hysteresis {hyst:.4f} CALIBRATED so the simulated Husky draws {current_a} A "
            f"per side driving straight at {speed_m_s} m/s (mean of the measured runs)"))
    return MappingProxyType(table)


TERRAINS: Mapping[str, TerrainParams] = _build()
TERRAIN_NAMES: tuple[str, ...] = tuple(TERRAINS)


def get_terrain(name: str) -> TerrainParams:
    """Terrain parameters by class name.

    Parameters
    ----------
    name : str
        Terrain class (case-insensitive), one of :data:`TERRAIN_NAMES`.

    Raises
    ------
    ConfigError
        Unknown name; the message lists the valid choices.

    Returns
    -------
    TerrainParams
        The catalogue entry (frozen).
    """
    key = str(name).upper()
    if key not in TERRAINS:
        raise ConfigError(f"unknown terrain {name!r}; valid choices: {', '.join(TERRAIN_NAMES)}")
    return TERRAINS[key]
