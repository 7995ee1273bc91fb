"""Vehicle-terrain simulator: vehicle + terrain + motors + sensors + scenarios.

Public API: :class:`SimConfig`, :func:`simulate` (returns a :class:`~terrain.run.Run`),
:func:`simulate_with_physics` (:class:`Simulation`: the run and the physics-rate truth),
:class:`Effects`, :func:`parse_effects`, :data:`PLANTED_EFFECTS`, :data:`EFFECT_NAMES`,
:data:`SCENARIO_NAMES`, :class:`SensorSettings`, :func:`minimum_duration_s` (shortest run the
readers accept), :func:`parse_terrain_list` (``"ICE,SNOW"`` -> names). Writing a run to files is
:func:`terrain.io.writer.write_run`.
"""

from __future__ import annotations

from terrain.sim.dynamics import PhysicsResult
from terrain.sim.effects import (EFFECT_NAMES, PLANTED_EFFECTS, Effects, PlantedEffect,
                                 parse_effects)
from terrain.sim.scenarios import SCENARIO_NAMES, Commands, make_commands
from terrain.sim.sensors import SensorSettings
from terrain.sim.simulate import (DEFAULT_SENSORS, SimConfig, Simulation, minimum_duration_s,
                                  parse_terrain_list, simulate, simulate_with_physics)

__all__ = ["EFFECT_NAMES", "PLANTED_EFFECTS", "PlantedEffect", "Effects", "parse_effects",
           "SCENARIO_NAMES", "Commands", "make_commands", "SensorSettings", "DEFAULT_SENSORS",
           "SimConfig", "Simulation", "PhysicsResult", "simulate", "simulate_with_physics",
           "minimum_duration_s", "parse_terrain_list"]
