"""``wrap_angle`` refuses what is not an angle with a typed error naming ``angle_rad``: None
and text were a bare TypeError, ``True`` the angle 1.0 rad; numbers wrap as before, in
Python and in numba code."""

import numpy as np
import pandas as pd
import pytest

from terrain.errors import EstimationError
from terrain.vehicles.common import wrap_angle


@pytest.mark.parametrize("bad, said", [
    (None, "got None"), ("a", "got 'a'"), (True, "got booleans"), (np.bool_(False), "got booleans"),
    (np.array([True, False]), "got booleans"), ([0.5, True], "got booleans"),
    (pd.Series([True]), "got booleans"), (1 + 2j, "complex128 is not a real number"),
    (np.array(["2020-01-01"], dtype="datetime64[D]"), "is not a real number")])
def test_what_is_not_an_angle_is_refused_naming_the_argument(bad, said):
    with pytest.raises(EstimationError, match=f"^wrap_angle: angle_rad must hold numbers, "
                                              f".*{said}"):
        wrap_angle(bad)


@pytest.mark.parametrize("angle", [4.0, -4.0, np.float64(3.5), np.pi, -np.pi, np.nan,
                                   np.linspace(-20.0, 20.0, 41),
                                   np.array([[7.0, -7.0], [0.0, np.inf]])])
def test_floats_and_float_arrays_wrap_by_the_one_formula(angle):
    a = np.asarray(angle, dtype=float)
    wrapped = (a + np.pi) % (2.0 * np.pi) - np.pi
    expected = wrapped - 2.0 * np.pi * (wrapped >= np.pi)
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(wrap_angle(angle), expected)


def test_integers_lists_and_pandas_numbers_are_angles():
    assert wrap_angle(4) == wrap_angle(4.0) == wrap_angle(np.int64(4))
    np.testing.assert_array_equal(wrap_angle([4.0, 1]), wrap_angle(np.array([4.0, 1.0])))
    out = wrap_angle(pd.Series([4.0, 1.0]))
    assert isinstance(out, pd.Series)           # (a pandas object stays one)
    np.testing.assert_array_equal(out.to_numpy(), wrap_angle(np.array([4.0, 1.0])))


@pytest.mark.slow
def test_wrap_angle_compiles_inside_numba_code():
    from numba import njit

    @njit
    def wrap_all(a):
        out = np.empty_like(a)
        for i in range(a.size):
            out[i] = wrap_angle(a[i])
        return out

    a = np.linspace(-20.0, 20.0, 101)
    np.testing.assert_array_equal(wrap_all(a), wrap_angle(a))
