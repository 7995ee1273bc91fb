"""Eighth review pass of the control grid (terrain.control.grid): the quasi-static bound's
inputs."""

from __future__ import annotations

import pytest

from terrain.control.grid import slip_limit_bound
from terrain.errors import ConfigError


@pytest.mark.parametrize("kwargs, field", [
    ({"accel_m_s2": 0.0}, "accel_m_s2"),          # ZeroDivisionError
    ({"accel_m_s2": -1.0}, "accel_m_s2"),         # a negative time to cruise
    ({"cruise_m_s": -1.0}, "cruise_m_s"),         # a negative time to cruise
    ({"cruise_m_s": float("inf")}, "cruise_m_s"),
    ({"cut": 1.5}, "cut"),                        # a negative slip limit, scored as reachable
    ({"cut": -0.1}, "cut"),
    ({"cut": float("nan")}, "cut"),
    ({"peak_slip_open": True}, "peak_slip_open"),  # read as a peak slip of 1
    ({"peak_slip_open": 1.2}, "peak_slip_open"),   # no SAE slip magnitude
    ({"peak_slip_open": -0.1}, "peak_slip_open"),
])
def test_the_slip_limit_bound_refuses_inputs_outside_their_range_naming_them(kwargs, field):
    """A commanded acceleration of 0 divided by zero, a cut above 1 gave a negative slip
    limit (TILES, peak 0.1, cut 1.5: -0.05) whose acceleration was scored as available, a
    negative speed or acceleration a negative time to cruise, True a peak slip of 1: each is
    refused with the argument named."""
    args = {"terrain": "TILES", "peak_slip_open": 0.1, **kwargs}
    with pytest.raises(ConfigError, match=field):
        slip_limit_bound(**args)


def test_the_slip_limit_bound_keeps_the_range_ends():
    """No cut keeps the peak as the limit, a full cut leaves slip 0 and no acceleration (inf
    to cruise); a peak of 0 is a run that never slipped."""
    assert slip_limit_bound("TILES", 0.1, cut=0.0)["slip_limit"] == pytest.approx(0.1)
    full = slip_limit_bound("TILES", 0.1, cut=1.0)
    assert full["slip_limit"] == 0.0 and full["min_time_to_cruise_s"] == float("inf")
    assert slip_limit_bound("TILES", 0.0)["slip_limit"] == 0.0


@pytest.mark.parametrize("seeds, bad", [([0, 0.5], r"seeds\[1\]"), (["a"], r"seeds\[0\]"),
                                        ([None], r"seeds\[0\]"), ([True, 1], r"seeds\[0\]"),
                                        ([1, -2], r"seeds\[1\]")])
def test_grid_seeds_that_are_not_whole_numbers_are_named_not_called_repeats(seeds, bad):
    """The axis check read each seed through int(): 0.5 became 0 and was reported as a
    repeat of seed 0, True as a repeat of 1, and text or None were Python's bare
    ValueError/TypeError. Each is now the seed named as not an integer >= 0."""
    from terrain.control.grid import check_grid_axes

    with pytest.raises(ConfigError, match=rf"^{bad} must be an integer >= 0"):
        check_grid_axes(["husky"], ["ICE"], ["straight_accel"], seeds)
    check_grid_axes(["husky"], ["ICE"], ["straight_accel"], [0, 1.0, 2])


def test_a_grid_seed_that_cannot_be_hashed_is_named_before_the_tuning_seed_check():
    """run_grid compared the seeds with the tuning seeds through set() first: a seed given
    as a list ([[1]]) was Python's bare "unhashable type: 'list'"."""
    from terrain.control.grid import run_grid

    with pytest.raises(ConfigError, match=r"^seeds\[0\] must be an integer >= 0, got \[1\]"):
        run_grid(["husky"], ["ICE"], ["straight_accel"], [[1]], {"husky": (1.0, 0.0)})
    with pytest.raises(ConfigError, match=r"evaluation seeds \[1000\] are tuning seeds"):
        run_grid(["husky"], ["ICE"], ["straight_accel"], [0, 1000], {"husky": (1.0, 0.0)})


def test_the_slip_limit_bound_names_the_catalogue_terrain():
    """A terrain given in another case is named as the catalogue names it, as every other
    table of the grid (ctl19's left-alone: 'ice' was returned as given)."""
    assert slip_limit_bound("ice", 0.1)["terrain"] == "ICE"
    assert slip_limit_bound("ice", 0.1) == slip_limit_bound("ICE", 0.1)
