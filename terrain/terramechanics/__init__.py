"""Wheel-terrain interaction: traction-slip curves, resistances and the terrain catalogue.

Public API: :func:`get_terrain`, :data:`TERRAINS`, :data:`TERRAIN_NAMES`,
:func:`traction_coefficient`, :func:`traction_curve_and_slope`, :func:`traction_peak`,
:func:`sae_slip` (the one SAE slip, :mod:`terrain.terramechanics.slip`),
:func:`soil_resistance_coefficient`, :func:`is_deformable`, :func:`grade_resistance_n`,
:func:`lateral_force_n`, :func:`turning_resistance_moment_nm`, :func:`can_turn_in_place`,
:func:`steady_slip`, :func:`calibrate_janosi`, :func:`husky_hysteresis_for_current`.
"""

from __future__ import annotations

from terrain.terramechanics.calibration import (calibrate_janosi, husky_hysteresis_for_current,
                                                steady_slip)
from terrain.terramechanics.catalogue import (MEASURED_HUSKY_STRAIGHT, TERRAIN_NAMES, TERRAINS,
                                              TerrainParams, get_terrain)
from terrain.terramechanics.resistance import (G_M_S2, bekker_compaction_coefficient,
                                               bekker_sinkage_m, can_turn_in_place,
                                               grade_resistance_n, is_deformable,
                                               lateral_force_n, soil_resistance_coefficient,
                                               turning_resistance_moment_nm)
from terrain.terramechanics.slip import (THESIS_DEAD_BAND_M_S, sae_slip,
                                         sae_slip_and_velocity_slope)
from terrain.terramechanics.traction import (BrixiusCurve, BurckhardtCurve, CurveCoefficients,
                                             JanosiCurve, TractionAndResistance, TractionCurve,
                                             TractionPeak,
                                             brixius_mobility_number, brixius_motion_resistance,
                                             brixius_traction, burckhardt_traction,
                                             janosi_traction, traction_coefficient,
                                             traction_curve_and_slope, traction_peak)

__all__ = [
    "MEASURED_HUSKY_STRAIGHT", "TERRAIN_NAMES", "TERRAINS", "TerrainParams", "get_terrain",
    "BrixiusCurve", "BurckhardtCurve", "JanosiCurve", "TractionAndResistance",
    "TractionCurve", "TractionPeak",
    "brixius_mobility_number", "sae_slip", "sae_slip_and_velocity_slope",
    "THESIS_DEAD_BAND_M_S", "CurveCoefficients", "brixius_motion_resistance",
    "brixius_traction", "burckhardt_traction", "janosi_traction", "traction_coefficient",
    "traction_curve_and_slope",
    "traction_peak", "G_M_S2", "bekker_compaction_coefficient", "bekker_sinkage_m",
    "can_turn_in_place", "grade_resistance_n", "is_deformable", "lateral_force_n",
    "soil_resistance_coefficient", "turning_resistance_moment_nm", "calibrate_janosi",
    "husky_hysteresis_for_current", "steady_slip",
]
