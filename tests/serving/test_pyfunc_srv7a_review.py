"""Review srv7a of :func:`terrain.serving.pyfunc.input_channels` (mutant: only ``vel_l,
vel_r`` added for a derived channel, no test failed; :func:`features.windows.
add_derived_channels` derives nothing unless all four wheel channels are there)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from features.windows import add_derived_channels
from terrain.serving.pyfunc import input_channels


def test_a_derived_channel_brings_all_four_raw_wheel_channels():
    assert input_channels(("cur_sum",)) == ["vel_l", "vel_r", "cur_l", "cur_r"]
    assert input_channels(("wx", "vel_diff", "cur_l")) == ["wx", "cur_l", "vel_l", "vel_r",
                                                           "cur_r"]
    assert input_channels(("wx", "vel_l")) == ["wx", "vel_l"]   # raw only: nothing added
    # and those four are what the derivation needs: cur_sum = cur_l + cur_r (A)
    raw = pd.DataFrame({c: np.full(3, x) for c, x in zip(input_channels(("cur_sum",)),
                                                         (0.5, 0.7, 4.0, 6.0))})
    np.testing.assert_allclose(add_derived_channels(raw)["cur_sum"], 10.0)
