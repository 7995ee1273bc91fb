"""The kinematics' array arguments (:func:`terrain.vehicles.common.float_arrays`) refuse
what is not a real number by the rule the data columns share, naming the argument and the
offending entry, where NumPy converted it to a float without a word."""

import re
import warnings

import numpy as np
import pytest

from terrain.errors import EstimationError
from terrain.vehicles import get_vehicle
from terrain.vehicles.common import float_arrays


@pytest.mark.parametrize("value, said", [
    (np.array([1 + 2j, 0.5]), "complex128 is not a real number"),    # was 1.0, 0.5
    (np.array(["2020-01-01"], dtype="datetime64[D]"), "datetime64[D] is not"),  # 18262.0
    (np.array([5], dtype="timedelta64[s]"), "timedelta64[s] is not"),   # was 5.0
    ([0.5, True], "bool True at index 1 is not a real number"),          # was 0.5, 1.0
    ([[0.5, 1.0], [np.True_, 2.0]], "bool np.True_ at index 2"),
    ([0.5, np.complex128(1 + 2j)], "complex128 is not a real number"),   # was 0.5, 1.0
    (np.array([0.5, None], dtype=object), "NoneType None at index 1"),
    (["0.5"], "<U3 is not a real number"),
])
def test_what_numpy_made_a_float_is_refused_naming_the_argument_and_entry(value, said):
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # (a complex array gave a ComplexWarning only)
        with pytest.raises(EstimationError, match=r"^f: omega must hold numbers, got .*\("
                           + re.escape(said)):
            float_arrays("f", torque=[1.0, 2.0], omega=value)


def test_a_motor_refuses_a_list_with_a_boolean_among_speeds():
    motor = get_vehicle("husky").motor
    with pytest.raises(EstimationError, match="omega_rad_s must hold numbers"):
        motor.current_from_torque([1.0, 1.0], [2.0, True])


@pytest.mark.parametrize("value", [
    [1.0, 2], (np.float32(1.5), np.int64(2)), [1.0, np.array(2.0)], np.arange(3),
    np.array([1.0, 2.0], dtype=object), 2.5, np.float64(2.5), [[1.0, 2.0], [3.0, 4.0]]])
def test_numbers_convert_as_numpy_converts_them(value):
    out, = float_arrays("f", x=value)
    assert out.dtype == float
    np.testing.assert_array_equal(out, np.asarray(value, dtype=float))
