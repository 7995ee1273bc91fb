"""Review of :mod:`terrain.serving.served` pieces that need no fitted model."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError
from terrain.serving.served import LONG_REQUEST_ROWS, LONG_REQUEST_S, check_settings, is_long


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


def test_min_confidence_is_taken_at_both_ends_of_its_range():
    # 0: never the conservative target; 1: always it unless certain (docs: "in [0, 1]")
    settings = {"hop_s": 0.5, "rate_hz": 20.0, "dwell_s": 10.0, "max_rows": 1,
                "max_decisions": 1}
    for conf in (0.0, 1.0):
        check_settings({**settings, "min_confidence": conf})
    with pytest.raises(ConfigError, match=r"min_confidence must be in \[0, 1\], got 1\.001"):
        check_settings({**settings, "min_confidence": 1.001})
