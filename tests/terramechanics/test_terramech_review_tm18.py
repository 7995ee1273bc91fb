"""Review tm18 of terrain.terramechanics: inputs refused by name, inverse slip outside its
domain, and Hypothesis properties of the traction curves, their peaks and the calibrations."""

import math

import pytest

from terrain.errors import ConfigError, DataWarning
from terrain.terramechanics import (TerrainParams, get_terrain, husky_hysteresis_for_current,
                                    sae_slip)
from terrain.terramechanics.slip import ground_speed_from_slip, rim_speed_from_slip


@pytest.mark.parametrize("v, s", [(1.0, 1.0), (0.0, 1.0), (-1.0, -1.0), (1.0, 1.5),
                                  (1.0, -1.5), (-1.0, 1.5)])
def test_rim_speed_from_slip_is_nan_where_no_rim_speed_gives_the_slip(v, s):
    # q = sign(v) s >= 1 divided by zero (ZeroDivisionError) or gave a rim running against
    # the ground (v 1, s 1.5: -2 m/s, whose slip is 1, not 1.5); q < -1 likewise
    assert all(math.isnan(x) for x in rim_speed_from_slip(v, s))


def test_rim_speed_from_slip_keeps_the_locked_wheel():
    # q = -1: a locked wheel on a moving body, rim speed 0 (eq. 7.2)
    rim = rim_speed_from_slip(2.0, -1.0)[0]
    assert rim == 0.0
    assert float(sae_slip(rim, 2.0, dead_band_m_s=0.0)) == -1.0
    assert float(ground_speed_from_slip(rim_speed_from_slip(2.0, 0.5)[0], 0.5)) == 2.0


@pytest.mark.parametrize("current_a", [0.0, -5.0, 0.5])
def test_husky_hysteresis_warns_of_a_current_below_what_the_traction_alone_draws(current_a):
    # it came out as hysteresis 0 without a word (tm5 keeps the 0), a terrain that then
    # draws more than the target
    with pytest.warns(DataWarning, match=r"current_a .* below the 2\.\d+ A"):
        assert husky_hysteresis_for_current(get_terrain("SNOW"), current_a, 0.5) == 0.0


def test_husky_hysteresis_round_trips_the_catalogue_calibration():
    snow = get_terrain("SNOW")
    assert husky_hysteresis_for_current(snow, 5.2, 0.37) == pytest.approx(snow.hysteresis)


@pytest.mark.parametrize("curve", [None, 0.5, "ASPHALT", (1.28, 23.99, 0.52)])
def test_terrain_params_refuses_a_curve_that_is_no_traction_curve(curve):
    # accepted, then an AttributeError ('NoneType' object has no attribute 'coefficients')
    # at the first traction or resistance asked of it, naming no field
    with pytest.raises(ConfigError, match="curve"):
        TerrainParams("X", curve, 0.1, 0.0, 0.5, 0.0, 0.0, 1.0, "test")
