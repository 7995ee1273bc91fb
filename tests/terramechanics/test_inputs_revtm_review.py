"""Review revtm: the array arguments of the slip, grade, lateral-friction and combined-slip
relations are refused, named, when they are not numbers (None was a silent NaN, a boolean
mask was a speed of 1 m/s, a pitch of 1 rad or a full slip, text raised NumPy's bare
ValueError) or when their shapes do not broadcast (NumPy's bare "operands could not be
broadcast")."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import DataFormatError, NonFiniteInputError, ShapeError
from terrain.terramechanics import get_terrain, grade_resistance_n, lateral_force_n, sae_slip
from terrain.terramechanics.combined_slip import combined_slip_coefficients
from terrain.terramechanics.resistance import lateral_force_and_slope
from terrain.terramechanics.slip import ground_speed_from_slip

NOT_NUMBERS = (None, True, np.array([True, False]), "0.1", "abc", ["0.1", "0.2"],
               np.array([0.1, None], dtype=object))
ASPHALT = get_terrain("ASPHALT").curve


@pytest.mark.parametrize("bad", NOT_NUMBERS, ids=repr)
def test_grade_resistance_refuses_a_pitch_that_is_not_numbers(bad):
    # None gave a NaN force, True the grade of a 1 rad (57 degree) slope, 'abc' a bare
    # ValueError naming no argument
    with pytest.raises(DataFormatError, match=r"grade_resistance_n: pitch_rad must be a number"):
        grade_resistance_n(50.0, bad)


@pytest.mark.parametrize("pitch", [np.inf, -np.inf, [0.1, np.inf]], ids=repr)
def test_grade_resistance_refuses_an_infinite_pitch(pitch):
    # sin(inf) was a NaN force behind NumPy's RuntimeWarning "invalid value encountered in sin"
    with pytest.raises(NonFiniteInputError, match=r"grade_resistance_n: pitch_rad .*infinite"):
        grade_resistance_n(50.0, pitch)


def test_grade_resistance_passes_a_nan_pitch_as_nan():
    # NaN is a number (a missing IMU sample): it passes, as in every slip relation
    assert np.isnan(grade_resistance_n(50.0, np.nan))


#: relation, its two array arguments (valid values), and how it is called
PAIRS = {
    # None raised "'<' not supported between 'NoneType' and 'float'", text NumPy's
    # UFuncTypeError, True a lateral speed of 1 m/s
    "lateral_force_and_slope": (lambda **a: lateral_force_n(0.5, **a), {
        "normal_load_n": np.array([100.0, 120.0]), "v_lateral_m_s": np.array([0.1, -0.1])}),
    # None gave NaN forces, True a full slip, text a bare ValueError
    "combined_slip_coefficients": (
        lambda **a: combined_slip_coefficients(ASPHALT, side_force_factor=0.8, **a), {
            "slip_long": np.array([0.1, 0.2]), "slip_side": np.array([0.0, 0.05])}),
    # None gave a NaN speed, True a slip of 1 (ground speed 0), text a bare ValueError
    "ground_speed_from_slip": (ground_speed_from_slip, {
        "rim_speed_m_s": np.array([0.5, 0.6]), "slip": np.array([0.1, -0.1])}),
}


@pytest.mark.parametrize("owner,which", [(o, w) for o, (_, a) in PAIRS.items() for w in a])
@pytest.mark.parametrize("bad", NOT_NUMBERS, ids=repr)
def test_relations_refuse_array_arguments_that_are_not_numbers(owner, which, bad):
    call, valid = PAIRS[owner]
    args = dict(valid, **{which: bad})
    with pytest.raises(DataFormatError, match=rf"{owner}: {which} must be"):
        call(**args)


def test_lateral_force_refuses_loads_and_speeds_of_other_shapes():
    with pytest.raises(ShapeError, match=r"normal_load_n of shape \(3,\) and v_lateral_m_s of "
                                         r"shape \(2,\)"):
        lateral_force_and_slope(0.5, np.ones(3), np.ones(2))


def test_combined_slip_refuses_slips_of_other_shapes():
    with pytest.raises(ShapeError, match=r"slip_long of shape \(3,\) and slip_side of shape"):
        combined_slip_coefficients(ASPHALT, np.zeros(3), np.zeros(2), 0.8)


@pytest.mark.parametrize("which", ["rim_speed_m_s", "v_long_m_s"])
@pytest.mark.parametrize("bad", [True, np.array([True, False])], ids=repr)
def test_sae_slip_refuses_boolean_speeds(which, bad):
    # a mask passed for a speed was a speed of 1 m/s: sae_slip(True, 0.5) gave slip 0.5
    args = {"rim_speed_m_s": np.array([0.5, 0.6]), "v_long_m_s": np.array([0.4, 0.5])}
    args[which] = bad
    with pytest.raises(DataFormatError, match=rf"sae_slip: {which} must hold numbers"):
        sae_slip(**args)


def test_ground_speed_from_slip_refuses_inputs_of_other_shapes():
    with pytest.raises(ShapeError, match=r"rim_speed_m_s of shape \(3,\) and slip of shape"):
        ground_speed_from_slip(np.ones(3), np.zeros(2))
