"""Review of :func:`terrain.serving.inputs.values_matrix`: a chunk's values are never
reshaped on a guess."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import DataFormatError
from terrain.serving.inputs import values_matrix

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
