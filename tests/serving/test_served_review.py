"""Review of :mod:`terrain.serving.served` pieces that need no fitted model."""

from __future__ import annotations

import numpy as np
import pandas as pd

from terrain.serving.served import LONG_REQUEST_ROWS, LONG_REQUEST_S, is_long


def test_the_long_lane_starts_above_its_row_and_second_bounds_not_at_them():
    # "more than 10,000 rows or 100 s of stream" (docs/streaming.md, README)
    rows = pd.DataFrame({"t_s": np.linspace(0.0, 1.0, LONG_REQUEST_ROWS)})
    assert not is_long(rows)
    assert is_long(pd.DataFrame({"t_s": np.linspace(0.0, 1.0, LONG_REQUEST_ROWS + 1)}))
    assert not is_long(pd.DataFrame({"t_s": [0.0, LONG_REQUEST_S]}))
    assert is_long(pd.DataFrame({"t_s": [0.0, LONG_REQUEST_S + 0.01]}))
    # the wide format's time columns count, each column's stamps together
    wide = pd.DataFrame({"imu_t_s": [5.0, 6.0], "wheels_t_s": [6.0, 5.0 + LONG_REQUEST_S + 1]})
    assert is_long(wide) and not is_long(wide.rename(columns={"wheels_t_s": "wheels"}))
