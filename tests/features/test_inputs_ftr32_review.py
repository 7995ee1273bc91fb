"""Public feature helpers refuse bad input with the project's typed errors (review ftr32).

Each case gave numbers without a word, or NumPy's / SciPy's bare error, on main.
"""

import numpy as np
import pytest

from features import calculators as C
from features.windows import check_uniform_clock, derived_wheel_arrays, required_streams
from terrain.errors import ConfigError, DataFormatError, ShapeError, TimestampError

RATE_HZ = 50.0
BANDS = ((0.0, 5.0), (5.0, 10.0))


@pytest.mark.parametrize("t_s, row", [
    (np.array([0.0, 0.02, 0.02, 0.04, 0.06, 0.08]), 2),     # a repeated time: passed
    (np.array([0.0, 0.02, np.nan, 0.06, 0.08]), 2),          # a NaN time: passed
    (np.array([0.08, 0.06, 0.04, 0.02, 0.0]), 1),            # backwards: "at -50 Hz"
])
def test_check_uniform_clock_refuses_times_off_a_strictly_increasing_clock(t_s, row):
    with pytest.raises(TimestampError) as err:
        check_uniform_clock(t_s, RATE_HZ, "run 7")
    assert (err.value.column, err.value.row, err.value.path) == ("t_s", row, "run 7")
    # the request's own row is named where given
    with pytest.raises(TimestampError) as err:
        check_uniform_clock(t_s, RATE_HZ, rows=np.arange(len(t_s)) + 100)
    assert err.value.row == row + 100


@pytest.mark.parametrize("rate_hz", [0.0, -50.0, np.nan, np.inf, True, "50"])
def test_check_uniform_clock_refuses_a_rate_that_is_not_a_positive_number(rate_hz):
    with pytest.raises(ConfigError, match="rate_hz"):
        check_uniform_clock(np.arange(5) * 0.02, rate_hz)


def test_check_uniform_clock_refuses_2d_times_and_rows_of_another_length():
    with pytest.raises(ShapeError, match="1-D"):
        check_uniform_clock(np.arange(10.0).reshape(5, 2) * 0.02, RATE_HZ)
    with pytest.raises(ShapeError, match="rows"):
        check_uniform_clock(np.arange(5) * 0.02, RATE_HZ, rows=np.arange(3))
    # a uniform clock still passes, an epoch one too
    check_uniform_clock(np.arange(100) * 0.02, RATE_HZ)
    check_uniform_clock(1.7e9 + np.arange(100) / RATE_HZ, RATE_HZ)


@pytest.mark.parametrize("channels", ["wz", None, 3])
def test_required_streams_refuses_text_and_non_sequences(channels):
    # "wz" was read as the channels 'w' and 'z' and answered ("wheels",)
    with pytest.raises(ConfigError, match="sequence of channel names"):
        required_streams(channels)


def test_required_streams_refuses_an_unknown_channel_naming_it():
    # a misspelt IMU channel was counted as a wheel channel: ("wheels",)
    with pytest.raises(ConfigError, match="'w_z'"):
        required_streams(["ax", "w_z"])
    assert required_streams(iter(["wz", "cur_l"])) == ("imu", "wheels")


@pytest.mark.parametrize("n", [0, -1, 2.5, True, None])
def test_hann_taper_refuses_a_length_that_is_not_a_positive_integer(n):
    with pytest.raises(ConfigError, match="n_samples"):
        C.hann_taper(n)


@pytest.mark.parametrize("x", [None, 3.0, np.ones((1, 1, 0)), np.ones((2, 1, 1))])
def test_band_log_power_refuses_windows_without_a_spectrum(x):
    # one sample read as a band power of exactly 0 (-12 in every band); a scalar or None
    # was NumPy's bare IndexError
    with pytest.raises(ShapeError, match="at least 2 samples"):
        C.band_log_power(x, RATE_HZ, BANDS)


def test_band_log_power_refuses_helpers_of_another_window_length_and_a_bad_rate():
    x = np.random.default_rng(0).normal(size=(2, 1, 100))
    w, taper = C.band_weights(100, RATE_HZ, BANDS), C.hann_taper(100)
    with pytest.raises(ShapeError, match="weights"):
        C.band_log_power(x, RATE_HZ, BANDS, weights=C.band_weights(60, RATE_HZ, BANDS))
    with pytest.raises(ShapeError, match="taper"):
        C.band_log_power(x, RATE_HZ, BANDS, weights=w, taper=C.hann_taper(60))
    for rate in (0.0, np.nan, "50", True):     # 0 Hz gave NaN band powers
        with pytest.raises(ConfigError, match="rate_hz"):
            C.band_log_power(x, rate, BANDS, weights=w, taper=taper)
    # given helpers or not, the same numbers
    assert np.array_equal(C.band_log_power(x, RATE_HZ, BANDS, weights=w, taper=taper),
                          C.band_log_power(x, RATE_HZ, BANDS))


def test_per_speed_refuses_masks_mismatched_shapes_and_empty_windows():
    cur, vel = np.full((2, 5), 3.0), np.full((2, 5), 0.5)
    with pytest.raises(DataFormatError, match="current"):
        C.per_speed(np.ones((2, 5), bool), vel, 0.05)     # read as 1 A
    with pytest.raises(DataFormatError, match="speed"):
        C.per_speed(cur, np.ones((2, 5), bool), 0.05)
    with pytest.raises(ShapeError):
        C.per_speed(cur, vel[:1], 0.05)      # one window's speed broadcast to both
    with pytest.raises(ShapeError):
        C.per_speed(np.ones((1, 0)), np.ones((1, 0)), 0.05)     # NaN and a RuntimeWarning
    with pytest.raises(ShapeError):
        C.per_speed(None, vel, 0.05)
    assert np.array_equal(C.per_speed(cur, vel, 0.05), [6.0, 6.0])
    assert np.array_equal(C.per_speed(cur.tolist(), (-vel).tolist(), 0.05), [6.0, 6.0])


def test_derived_wheel_arrays_refuses_masks_and_mismatched_shapes():
    a = np.array([0.2, 0.4, 0.6])
    with pytest.raises(DataFormatError, match="vel_r"):
        derived_wheel_arrays(a, np.ones(3, bool), a, a)
    with pytest.raises(ShapeError, match="one shape"):
        derived_wheel_arrays(a, a[:1], a, a)     # one sample broadcast to every row
    with pytest.raises(ShapeError, match="one shape"):
        derived_wheel_arrays(None, a, a, a)
    out = derived_wheel_arrays([0.2, 0.4], [0.4, 0.4], [1.0, 2.0], [3.0, 2.0], 0.5)
    assert np.allclose(out["yaw_rate_wheels"], [0.4, 0.0])
    assert np.array_equal(out["cur_diff"], [2.0, 0.0])
