"""A boolean among numbers (``[0.5, True]``) is a boolean where numbers are meant:
:func:`terrain.errors.holds_booleans` looked only at the dtype NumPy gave a list, float,
so the traction step, the EKF and the simulator read ``True`` as 1.0 without a word."""

import numpy as np
import pandas as pd
import pytest

from terrain.errors import (ConfigError, DataFormatError, EstimationError, first_boolean,
                            holds_booleans, refuse_booleans)


@pytest.mark.parametrize("value", [
    [0.5, True], (1.0, np.True_), [[0.5, 1.0], [False, 2.0]], [0.5, np.array(True)],
    [None, True]])
def test_a_boolean_among_numbers_is_seen(value):
    assert holds_booleans(value)


@pytest.mark.parametrize("value", [
    0.5, np.float64(0.5), 3, np.ones(3), [0.5, 1], (np.float32(1.5), np.int64(2)), [],
    [[1.0], [2.0, 3.0]], np.array([0.5, "a"], dtype=object), pd.Series([1.0, 2.0]),
    [0.5, np.array(2.0)], "True", None])
def test_numbers_and_what_is_not_a_boolean_pass(value):
    assert not holds_booleans(value)


def test_first_boolean_gives_the_flattened_index_and_entry():
    assert first_boolean([[0.5, 1.0], [2.0, np.True_]]) == (3, np.True_)
    assert first_boolean([0.5, 1.0]) is None
    whole = [True, False]
    assert first_boolean(whole)[1] is whole


def test_refuse_booleans_names_the_entry_of_a_boolean_among_numbers():
    with pytest.raises(EstimationError, match=r"^f: b must hold numbers, got booleans "
                       r"\(bool True at index 1 is not a real number\)$"):
        refuse_booleans(EstimationError, "f", a=[1.0, 2.0], b=[0.5, True])


def test_the_ekf_refuses_a_boolean_among_measurements():
    from terrain.estimation.ekf import ExtendedKalmanFilter

    kf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), lambda x, dt: x,
                              lambda x, dt: np.eye(2), lambda x: x, lambda x: np.eye(2),
                              np.eye(2), np.ones(2))
    with pytest.raises(EstimationError, match="z must hold numbers, got booleans"):
        kf.update([0.5, True])                 # was the measurement (0.5, 1.0)
    kf.update([0.5, 1.0])                      # numbers pass


def test_the_traction_step_refuses_a_boolean_among_wheel_speeds():
    from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionState,
                                          traction_control_step)

    cfg, targets = TractionControlConfig(), SlipTargets(0.1, -0.15, 0.05)
    args = (np.array([10.0, 10.0]), np.array([10.0, 10.0]), np.array([1.0, 1.0]),
            np.zeros(2), 1.0, 0.02)
    traction_control_step(cfg, TractionState.zeros(2), targets, *args)
    with pytest.raises(DataFormatError, match="omega_low_level_rad_s must hold real numbers"):
        traction_control_step(cfg, TractionState.zeros(2), targets, [10.0, True], *args[1:])


def test_the_simulator_refuses_a_boolean_among_commands():
    from terrain.sim.dynamics import integrate
    from terrain.terramechanics import get_terrain
    from terrain.vehicles import get_vehicle

    husky = get_vehicle("husky")
    cmd = [[0.5, 0.0, 0.0], [0.5, 0.0, True]]      # a yaw rate of 1 rad/s before
    with pytest.raises(ConfigError, match="twist_cmd must hold numbers, got booleans"):
        integrate(husky, husky.contact_geometry(), (get_terrain("ASPHALT"),), 1e9,
                  [0.0, 0.01], cmd, 0.0, 1.0)
