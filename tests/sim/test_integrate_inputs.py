"""The integrator refuses a time grid, command or terrain it cannot step (a typed error naming
the argument, not a bare IndexError/ZeroDivisionError or a run made of garbage)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError, NonFiniteInputError, ShapeError, TimeStepError
from terrain.sim.dynamics import integrate
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

HUSKY = get_vehicle("husky")
ASPHALT = (get_terrain("ASPHALT"),)
T = np.arange(21) * 0.01
CMD = np.column_stack([np.full(21, 0.5), np.zeros(21), np.zeros(21)])


def _run(t_s=T, twist=CMD, terrains=ASPHALT, segment=25.0, slope=0.0, chi=1.0):
    return integrate(HUSKY, HUSKY.contact_geometry(), terrains, segment, t_s, twist, slope,
                     chi)


@pytest.mark.parametrize("t_s", [-T, np.zeros(21), T[::-1].copy()])
def test_a_time_grid_that_does_not_advance_is_refused(t_s):
    # -T integrated backwards (the Husky ended at x = -3.9 m, turned by 0.4 rad, for a
    # straight 0.5 m/s command); zeros divided by a step of 0 (NaN accelerations)
    with pytest.raises(TimeStepError, match="t_s"):
        _run(t_s=t_s)


def test_a_time_grid_that_is_not_uniform_is_refused():
    # the step was read from the first two samples only: t^2 was integrated at 1e-4 s
    with pytest.raises(TimeStepError, match="uniform"):
        _run(t_s=T ** 2)
    with pytest.raises(NonFiniteInputError, match="t_s"):
        _run(t_s=np.r_[T[:-1], np.nan])


def test_a_grid_far_from_zero_with_rounded_steps_is_accepted():
    # a replay's grid (start + k dt, then less the start) has steps rounded by the start
    t = (1.7e9 + T) - 1.7e9
    assert _run(t_s=t).pose.shape == (21, 3)


@pytest.mark.parametrize("twist", [CMD[:10], np.vstack([CMD, CMD]), CMD[:, :2]])
def test_a_command_without_one_twist_per_step_is_refused(twist):
    # 10 rows: IndexError at step 10; 42 rows: the last 21 silently ignored
    with pytest.raises(ShapeError, match="twist_cmd"):
        _run(twist=twist)


def test_a_non_finite_command_is_refused():
    bad = CMD.copy()
    bad[10, 0] = np.nan       # was ValueError 'cannot convert float NaN to integer'
    with pytest.raises(NonFiniteInputError, match="twist_cmd"):
        _run(twist=bad)


@pytest.mark.parametrize("segment", [0.0, -1.0, float("nan")])
def test_a_segment_length_that_is_not_positive_is_refused(segment):
    # 0 was a ZeroDivisionError, NaN a ValueError, -1 accepted (the terrain index ran
    # backwards through the tuple)
    with pytest.raises(ConfigError, match="segment_length_m"):
        _run(segment=segment)


def test_an_infinite_segment_keeps_the_first_terrain():
    p = _run(terrains=(get_terrain("ASPHALT"), get_terrain("ICE")), segment=float("inf"))
    assert np.all(p.terrain_index == 0)


def test_no_terrain_or_a_bad_slope_or_chi_is_refused():
    with pytest.raises(ConfigError, match="terrain"):
        _run(terrains=())             # was ZeroDivisionError 'integer modulo by zero'
    with pytest.raises(ConfigError, match="slope_rad"):
        _run(slope=float("nan"))
    for chi in (float("nan"), 0.0, 0.5):
        with pytest.raises(ConfigError, match="chi"):
            _run(chi=chi)
