"""The closed loop, the effects parser and the stream rates refuse an argument they cannot
use (a controller rate, sensor settings, one string for a list), with a typed error naming
it."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim import SensorSettings, SimConfig, minimum_duration_s, parse_effects
from terrain.sim.closed_loop import (OnlineSensors, make_hook, replay_observations,
                                     simulate_closed_loop)
from terrain.sim.simulate import simulate_with_physics, stream_rates_hz

CONFIG = SimConfig(vehicle="husky", scenario="spin", duration_s=0.5, seed=1)


def _zero(observation):
    return np.zeros(2)


@pytest.mark.parametrize("rate", [True, "50", None, float("nan"), 0.0, -10.0])
def test_a_control_rate_that_is_not_a_positive_number_is_refused(rate):
    # True ran the controller at 1 Hz without a word; "50" and None were bare TypeErrors
    with pytest.raises(ConfigError, match="control_rate_hz"):
        simulate_closed_loop(CONFIG, _zero, control_rate_hz=rate)
    with pytest.raises(ConfigError, match="control_rate_hz"):
        list(replay_observations(simulate_with_physics(CONFIG), control_rate_hz=rate))


@pytest.mark.parametrize("rate", [True, "50", float("inf"), 0.0])
def test_make_hook_refuses_a_bad_rate(rate):
    # inf gave a period of 0: the controller was called on every physics step
    sensors = OnlineSensors("husky", SensorSettings(), 0, 1.0)
    with pytest.raises(ConfigError, match="control_rate_hz"):
        make_hook(sensors, _zero, rate)


@pytest.mark.parametrize("sensors", [None, {"imu_rate_hz": 100.0}])
def test_online_sensors_refuse_settings_that_are_not_sensor_settings(sensors):
    # was AttributeError "'NoneType' object has no attribute 'accel_bias_std_m_s2'"
    with pytest.raises(ConfigError, match="OnlineSensors.sensors must be SensorSettings"):
        OnlineSensors("husky", sensors, 0, 1.0)


def test_online_sensors_refuse_one_string_of_terrains():
    # "SNOW" was split into letters: "unknown terrain 'S'"
    with pytest.raises(ConfigError, match="sequence of terrain names"):
        OnlineSensors("husky", SensorSettings(), 0, 1.0, terrains="SNOW")
    assert [t.name for t in OnlineSensors("husky", SensorSettings(), 0, 1.0,
                                          terrains=("SNOW",)).terrains] == ["SNOW"]


def test_parse_effects_refuses_one_string_instead_of_a_list_of_items():
    # "gyro_bias=0.1" was iterated letter by letter: "effect 'g' is not NAME=VALUE"
    with pytest.raises(ConfigError, match="sequence of NAME=VALUE items.*'gyro_bias=0.1'"):
        parse_effects("gyro_bias=0.1")
    assert parse_effects(["gyro_bias=0.1"]).gyro_bias == 0.1


def test_stream_rates_refuse_settings_that_are_not_sensor_settings():
    # {} (falsy) silently gave the vehicle's defaults, "x" was an AttributeError
    for bad in ({}, "x", 3):
        with pytest.raises(ConfigError, match="sensors must be SensorSettings"):
            stream_rates_hz("husky", bad)
        with pytest.raises(ConfigError, match="sensors must be SensorSettings"):
            minimum_duration_s("husky", bad)
    assert stream_rates_hz("husky", None) == stream_rates_hz("husky", SensorSettings())
