"""Seed slip baselines and dead reckoning at their documented boundaries."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from terrain.errors import ConfigError, DataWarning, ShapeError, TimeStepError
from terrain.slip.baselines import (endo_turning_slip, fit_pitch_slip, observer_slip,
                                    pitch_slip, slip_ratio_as_sae)
from terrain.slip.odometry import BRAKING_SLIP_FLOOR, dead_reckon


def test_pitch_line_is_fitted_over_a_pitch_span_of_a_few_hundredths():
    pitch = np.linspace(0.0, 0.05, 6)            # 0.05 rad: above the 0.01 rad floor
    coef = fit_pitch_slip(pitch, 0.02 + 0.4 * pitch, ["SNOW"] * 6)
    assert coef["SNOW"] == pytest.approx((0.02, 0.4))
    flat = fit_pitch_slip(np.full(3, 0.1) + [0.0, 0.002, 0.004], [0.1, 0.2, 0.3], ["SNOW"] * 3)
    assert flat["SNOW"] == pytest.approx((0.2, 0.0))


def test_endo_slip_is_defined_from_the_turn_threshold_on_and_not_for_a_still_side():
    vl, vr = np.array([0.2, 0.2, 0.2]), np.array([0.5, 5e-4, 0.5])
    out = endo_turning_slip(vl, vr, np.array([0.1, -0.5, 0.0999]), 0.5, min_turn_rad_s=0.1)
    assert np.isfinite(out[0]).all()                    # |yaw rate| == threshold: a turn
    assert np.isnan(out[1]).all()                       # right side (nearly) still
    assert np.isnan(out[2]).all()                       # below the threshold


def test_endo_slip_exactly_at_plus_minus_one_is_not_counted_as_clipped():
    # equal side speeds: rho = -1, alpha_r = -B w / (2 v) = 1 exactly, alpha_l = -1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = endo_turning_slip(np.array([1.0]), np.array([1.0]), np.array([-2.0]), 1.0)
    np.testing.assert_array_equal(out, [[-1.0, 1.0]])


def test_slip_ratio_as_sae_has_no_dead_band_at_creeping_speed():
    # rim 2 cm/s, alpha 0.5: ground 1 cm/s, SAE 0.5 (the slow speed is a convention change
    # only, not the thesis's dead band that would report 0)
    np.testing.assert_allclose(slip_ratio_as_sae(np.array([0.02, -0.02]), np.array([0.5, 0.5])),
                               [0.5, -0.5])


def test_observer_refuses_a_zero_half_track():
    t = np.arange(0.0, 1.0, 0.1)
    with pytest.raises(ConfigError, match="half_track_m"):
        observer_slip(t, np.zeros_like(t), np.ones_like(t), np.ones_like(t), 0.0)


@pytest.mark.parametrize("half_track", ["0.3", [0.3], None])
def test_observer_names_a_half_track_that_is_not_a_number(half_track):
    # text made the '> 0' check raise Python's bare TypeError, naming nothing
    t = np.arange(0.0, 1.0, 0.1)
    with pytest.raises(ConfigError, match="observer_slip.half_track_m"):
        observer_slip(t, np.zeros_like(t), np.ones_like(t), np.ones_like(t), half_track)


def test_pitch_slip_is_the_eq22_line_of_each_window_terrain():
    coef = {"SNOW": (0.02, 0.4), "ICE": (0.1, -1.0)}
    out = pitch_slip(coef, np.array([0.05, 0.05, 0.0]), ["SNOW", "ICE", "GRASS"])
    np.testing.assert_allclose(out, [0.04, 0.05, np.nan])


@pytest.mark.parametrize("terrains", [["SNOW", "SNOW"], "SNOW"])
def test_pitch_slip_refuses_terrains_of_another_length(terrains):
    # two labels for three pitches raised numpy's bare IndexError; one bare string gave its
    # terrain's line to every window whatever it was
    with pytest.raises(ShapeError, match="terrains"):
        pitch_slip({"SNOW": (0.02, 0.4)}, np.zeros(3), terrains)


@pytest.mark.parametrize("track", [np.inf, True, "0.5", np.nan, -0.5])
def test_dead_reckon_names_a_track_that_is_not_a_finite_length(track):
    # inf divided the wheels' yaw rate to 0: a turning robot (0.9 / 1.1 m/s) was
    # dead-reckoned straight ([0.4, 0, 0] after 0.4 s); True drove a 1 m track; text raised a
    # bare TypeError
    t = np.arange(5) * 0.1
    with pytest.raises(ConfigError, match="dead_reckon.track_m"):
        dead_reckon(t, np.full(5, 0.9), np.full(5, 1.1), track)


def test_dead_reckon_takes_any_track_with_a_measured_yaw_rate():
    t = np.arange(5) * 0.1          # the track is unused when the gyro gives the heading
    pose = dead_reckon(t, np.ones(5), np.ones(5), np.nan, yaw_rate_rad_s=np.zeros(5))
    np.testing.assert_allclose(pose[-1], [0.4, 0.0, 0.0])


def test_dead_reckon_refuses_a_repeated_time():
    t = np.array([0.0, 0.1, 0.1, 0.2])
    with pytest.raises(TimeStepError, match="strictly increasing"):
        dead_reckon(t, np.ones(4), np.ones(4), 0.5)


def test_dead_reckon_slip_exactly_at_the_braking_floor_is_not_said_to_be_held():
    t = np.arange(4.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        pose = dead_reckon(t, np.ones(4), np.ones(4), 0.5, np.full(4, BRAKING_SLIP_FLOOR),
                           np.full(4, BRAKING_SLIP_FLOOR))
    assert pose[-1, 0] == pytest.approx(3.0 / (1.0 + BRAKING_SLIP_FLOOR))


def test_dead_reckon_follows_a_constant_turn_along_its_arc():
    # 1 m/s at 1 rad/s for 1 s: the circle x = sin(1), y = 1 - cos(1); the midpoint heading
    # keeps the error at ~(w dt)^2 / 24 of the step (the start heading was off by ~0.04 m)
    t = np.arange(11) * 0.1
    pose = dead_reckon(t, np.ones(11), np.ones(11), 0.5, yaw_rate_rad_s=np.ones(11))
    np.testing.assert_allclose(pose[-1], [np.sin(1.0), 1.0 - np.cos(1.0), 1.0], atol=1e-3)


def test_dead_reckon_turns_a_sideways_slide_with_the_body():
    # sliding 1 m/s to the body's left while turning at 1 rad/s: world velocity
    # (-sin(wt), cos(wt)), so x = cos(1) - 1 < 0 and y = sin(1) after 1 s
    t = np.arange(11) * 0.1
    pose = dead_reckon(t, np.zeros(11), np.zeros(11), 0.5, lateral_m_s=1.0,
                       yaw_rate_rad_s=np.ones(11))
    np.testing.assert_allclose(pose[-1], [np.cos(1.0) - 1.0, np.sin(1.0), 1.0], atol=1e-3)


def test_dead_reckon_reversing_in_traction_goes_slower_than_the_rims():
    # rim -0.3 m/s, SAE slip -1/3 (traction while reversing, signed by the travel): ground
    # -0.2 m/s, 0.2 m back after 1 s, and no slip held at the braking floor
    t = np.arange(11) * 0.1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pose = dead_reckon(t, np.full(11, -0.3), np.full(11, -0.3), 0.5, -1 / 3, -1 / 3)
    np.testing.assert_allclose(pose[-1], [-0.2, 0.0, 0.0], atol=1e-12)


def test_dead_reckon_slip_of_exactly_one_is_not_said_to_be_held():
    t = np.arange(4.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # 1 is the SAE saturation itself, not beyond it
        pose = dead_reckon(t, np.ones(4), np.ones(4), 0.5, 1.0, 1.0)
    np.testing.assert_allclose(pose[-1], [0.0, 0.0, 0.0], atol=1e-12)


def test_fit_pitch_slip_leaves_a_nan_slip_window_out_and_counts_it():
    pitch = np.linspace(0.0, 0.05, 6)
    slip = 0.02 + 0.4 * pitch
    slip[2] = np.nan
    with pytest.warns(DataWarning, match="1 of 6 windows"):
        coef = fit_pitch_slip(pitch, slip, ["SNOW"] * 6)
    assert coef["SNOW"] == pytest.approx((0.02, 0.4))
