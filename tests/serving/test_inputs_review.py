"""Review of :func:`terrain.serving.inputs.values_matrix`: a chunk's values are never
reshaped on a guess."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import DataFormatError
from terrain.serving.inputs import real_array, values_matrix

CHANNELS = ["vel_l", "vel_r", "cur_l", "cur_r"]


def test_one_sample_may_be_a_row_and_one_channel_a_column():
    assert values_matrix(np.arange(4.0), 1, CHANNELS, "wheels").shape == (1, 4)
    assert values_matrix(np.arange(3.0), 3, ["x"], "imu").shape == (3, 1)


@pytest.mark.parametrize("n", [2, 4])
def test_a_flat_row_of_one_value_per_channel_is_not_taken_for_several_samples(n):
    # four values for four channels is one sample; for a chunk of 2 or 4 samples it is
    # refused in the project's words (not numpy's reshape error, nor read as one sample)
    with pytest.raises(DataFormatError, match=rf"expected values of shape \({n}, 4\)"):
        values_matrix(np.arange(4.0), n, CHANNELS, "wheels")


@pytest.mark.parametrize("x", ["10.5", ["1.5", "2"], np.array(["1", "2"]), np.array([b"1.5"]),
                               np.array(["1.0"], dtype=object), np.array([1.0, "2"], dtype=object),
                               np.array([True, 1.0], dtype=object)])
@pytest.mark.parametrize("column", ["t_s", "vel_l", "values"])
def test_numbers_written_as_text_or_booleans_in_an_object_array_are_refused(x, column):
    # NumPy converts text that spells a number ("10.5" was taken as 10.5 s) and an object
    # array's booleans (True as 1.0) without a word; the docstring and README promise a
    # DataFormatError for text and booleans
    with pytest.raises(DataFormatError, match=f"{column} must hold real numbers"):
        real_array(x, "wheels", column)


def test_an_object_array_of_numbers_and_missing_values_is_read():
    got = real_array(np.array([1.0, None, 2], dtype=object), "wheels", "t_s")
    np.testing.assert_array_equal(got, [1.0, np.nan, 2.0])


def test_same_values_is_float32_precision_not_looser():
    """A re-sent sample's values may have gone through float32 (a relative error under
    6e-8); values 1e-5 apart (a current of 15.04 A against 15.04015 A) are other values."""
    from terrain.serving.inputs import same_values

    a = np.array([15.04, -0.094, np.nan])
    assert same_values(a, a.astype(np.float32).astype(float))
    assert not same_values(a, a * (1 + 1e-5))
    assert not same_values(a, np.array([15.04, -0.094, 1.0]))   # NaN against a number


def test_a_channel_given_as_two_dataframe_columns_is_named():
    """A DataFrame with two 'vel_l' columns (a join gone wrong) was refused with
    "vel_l must be one number or a 1-D array, got shape (2, 2)": true, but not why."""
    import pandas as pd

    from terrain.serving.inputs import chunk_values

    channels = ["vel_l", "vel_r"]
    frame = pd.DataFrame([[0.1, 0.2, 0.3], [0.1, 0.2, 0.3]],
                         columns=["vel_l", "vel_r", "vel_l"])
    with pytest.raises(DataFormatError, match=r"stream 'wheels': channel\(s\) \['vel_l'\] "
                                              r"given as several columns") as info:
        chunk_values(frame, np.array([0.0, 0.1]), channels, "wheels")
    assert info.value.column == "vel_l"
    # a duplicated column the stream does not read is not read, so not refused
    other = pd.DataFrame([[0.1, 0.2, 9.0, 9.0]], columns=["vel_l", "vel_r", "x", "x"])
    np.testing.assert_array_equal(chunk_values(other, np.array([0.0]), channels, "wheels"),
                                  [[0.1, 0.2]])
