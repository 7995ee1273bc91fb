"""Review ctl24: inputs of the control layer's public helpers that stopped on a bare Python
or NumPy error, or were taken silently (a boolean as a number, a label of another type), now
get a typed error from :mod:`terrain.errors` naming the argument; valid inputs give the same
results as before."""

import math

import numpy as np
import pytest

from terrain.control.closed_loop import default_gains, fallback_basis
from terrain.control.desired_slip import (DesiredSlipConfig, SlipTable, build_slip_table,
                                          confidence_is_trusted, fallback_entry)
from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionController,
                                      TractionState, age_is_fresh,
                                      encoder_resolution_speed_m_s, traction_control_step)
from terrain.errors import ConfigError
from terrain.vehicles import get_vehicle

TARGETS = SlipTargets(0.1, -0.15, 0.05)


def _step(config):
    one = np.array([1.0])
    return traction_control_step(config, TractionState.zeros(1), TARGETS, one, one,
                                 np.array([0.9]), np.array([0.0]), 0.9, 0.02)


@pytest.mark.parametrize("config", [None, {"kp": 1.0}, (1.0, 0.0)])
def test_step_refuses_a_config_that_is_not_a_traction_control_config(config):
    with pytest.raises(ConfigError, match="config"):
        _step(config)
    with pytest.raises(ConfigError, match="config"):
        TractionController(config, 1)


def test_step_with_a_real_config_is_unchanged():
    out, _ = _step(TractionControlConfig(kp=1.0))
    # slip 0.1 at the traction target, steady power: error 0, no correction
    assert out.correction_rad_s.tolist() == [0.0]
    assert out.slip.tolist() == pytest.approx([0.1])


@pytest.mark.parametrize("age", ["0.05", True, np.array([0.05, 0.06]), [0.05]])
def test_age_is_fresh_refuses_an_age_that_is_not_a_number(age):
    with pytest.raises(ConfigError, match="age_s"):
        age_is_fresh(age, 0.1)


@pytest.mark.parametrize("max_age", [None, "0.1", True, math.nan, -0.1, math.inf])
def test_age_is_fresh_refuses_a_limit_that_is_not_a_finite_age(max_age):
    with pytest.raises(ConfigError, match="max_age_s"):
        age_is_fresh(0.05, max_age)


@pytest.mark.parametrize("age, expected", [
    (0.0, True), (0.1, True), (0.05, True), (np.float64(0.05), True), (0, True),
    (0.1000001, False), (-1e-12, False), (None, False), (math.nan, False),
    (math.inf, False), (-math.inf, False)])
def test_age_is_fresh_on_valid_ages(age, expected):
    assert bool(age_is_fresh(age, 0.1)) is expected
    assert bool(age_is_fresh(age, np.float64(0.1))) is expected


@pytest.mark.parametrize("n", [True, -1, 0, 2.5, "3", None])
def test_state_zeros_refuses_a_count_that_is_not_an_integer_of_one_or_more(n):
    with pytest.raises(ConfigError, match="n"):
        TractionState.zeros(n)


def test_state_zeros_of_numpy_integer():
    state = TractionState.zeros(np.int64(3))
    assert [a.shape for a in state] == [(3,)] * 6


@pytest.mark.parametrize("threshold", [None, "0.5", True, math.nan, -0.1, 1.5])
def test_confidence_is_trusted_refuses_a_threshold_that_is_not_a_probability(threshold):
    with pytest.raises(ConfigError, match="min_confidence"):
        confidence_is_trusted(0.7, threshold)


@pytest.mark.parametrize("confidence, threshold, expected", [
    (0.5, 0.5, True), (0.4999, 0.5, False), (1.0, 1.0, True), (0.0, 0.0, True),
    (0.7, np.float64(0.5), True), (0.7, 0, True), (None, 0.5, False)])
def test_confidence_is_trusted_on_valid_thresholds(confidence, threshold, expected):
    assert confidence_is_trusted(confidence, threshold) is expected


def _table():
    return build_slip_table(["ICE", "TILES"])


@pytest.mark.parametrize("entries", ["ICE", [1, 2], {"ICE": 1}])
def test_fallback_entry_refuses_entries_that_are_not_table_rows(entries):
    with pytest.raises(ConfigError, match="entries"):
        fallback_entry(entries)


def test_fallback_entry_refuses_the_keys_of_a_table():
    with pytest.raises(ConfigError, match="entries"):
        fallback_entry(_table().entries)


def test_fallback_entry_reads_an_iterator_once():
    table = _table()
    rows = list(table.entries.values())
    assert fallback_entry(iter(rows)) == fallback_entry(rows) == table.fallback


@pytest.mark.parametrize("field, value", [("entries", None), ("entries", ["ICE"]),
                                          ("entries", {"ICE": 0.1}), ("fallback", None),
                                          ("fallback", (0.1, -0.1, 0.0)), ("config", None)])
def test_slip_table_refuses_parts_of_the_wrong_type(field, value):
    table = _table()
    parts = {"entries": dict(table.entries), "fallback": table.fallback,
             "config": table.config, field: value}
    with pytest.raises(ConfigError, match=field):
        SlipTable(**parts)


def test_slip_table_of_valid_parts_is_unchanged():
    table = _table()
    again = SlipTable(dict(table.entries), table.fallback, DesiredSlipConfig())
    assert dict(again.entries) == dict(table.entries) and again.fallback == table.fallback


@pytest.mark.parametrize("table", [None, {"ICE": 0.1}])
def test_fallback_basis_refuses_a_table_that_is_not_a_slip_table(table):
    with pytest.raises(ConfigError, match="fallback_basis"):
        fallback_basis(table)


@pytest.mark.parametrize("motor", [None, "agrimaro", 0.12])
def test_encoder_resolution_refuses_a_motor_that_is_not_a_drive(motor):
    with pytest.raises(ConfigError, match="motor"):
        encoder_resolution_speed_m_s(motor, 0.165)


def test_encoder_resolution_of_the_agrimaro_is_unchanged():
    motor = get_vehicle("agrimaro").motor
    expected = 0.165 * (2 * math.pi / 90) / (0.12 * 0.25)
    assert encoder_resolution_speed_m_s(motor, 0.165) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("vehicle, estimator, name", [
    (["husky"], None, "vehicle"), ("husky", "bogus", "bogus"),
    ("agrimaro", "observer", "observer"), ("husky", 5, "5")])
def test_default_gains_refuses_an_unknown_vehicle_or_estimator(vehicle, estimator, name):
    with pytest.raises(ConfigError, match=name):
        default_gains(vehicle, estimator)


@pytest.mark.parametrize("vehicle, estimator, gains", [
    ("husky", None, (2.0, 0.0)), ("husky", "fused", (2.0, 0.0)),
    ("husky", "observer", (5.0, 0.0)), ("agrimaro", None, (5.0, 0.0)),
    ("agrimaro", "ekf-vo", (5.0, 0.0))])
def test_default_gains_of_known_pairs(vehicle, estimator, gains):
    assert default_gains(vehicle, estimator) == gains
