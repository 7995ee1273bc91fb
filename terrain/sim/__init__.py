"""Vehicle-terrain simulator: vehicle + terrain + motors + sensors + scenarios.

Public API: :class:`SimConfig`, :func:`simulate`, :class:`SimResult`, :func:`write_run`,
:class:`Effects`, :func:`parse_effects`, :data:`EFFECT_NAMES`, :data:`SCENARIO_NAMES`,
:class:`SensorSettings`.
"""

from __future__ import annotations

from terrain.sim.effects import EFFECT_NAMES, EFFECTS, Effects, parse_effects
from terrain.sim.scenarios import SCENARIO_NAMES, Commands, make_commands
from terrain.sim.sensors import SensorSettings
from terrain.sim.simulate import DEFAULT_SENSORS, SimConfig, SimResult, simulate
from terrain.sim.writer import next_index, write_run

__all__ = ["EFFECT_NAMES", "EFFECTS", "Effects", "parse_effects", "SCENARIO_NAMES", "Commands",
           "make_commands", "SensorSettings", "DEFAULT_SENSORS", "SimConfig", "SimResult",
           "simulate", "next_index", "write_run"]
