"""Windowing edges found by mutation and input probes (review ftr32).

A clock missing one row (a step of two periods) must be refused: windows are cut by row, so
the window over it would join samples 40 ms apart as if 20 ms apart; a ``> 2.5`` periods
threshold instead of ``> 1.5`` passed every test. A frame column of booleans was cut into
windows of 0 and 1, and one of text failed in pandas naming no column.
"""

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig, add_derived_channels, check_uniform_clock, window_frame
from terrain.errors import ConfigError, DataFormatError, TimestampError

RATE_HZ = 50.0


@pytest.mark.parametrize("missing_row", [1, 37, 98])
def test_one_missing_row_is_a_hole_named_by_the_row_after_it(missing_row):
    t = np.delete(np.arange(100) / RATE_HZ, missing_row)     # one step of 2 periods
    with pytest.raises(TimestampError) as err:
        check_uniform_clock(t, RATE_HZ)
    assert (err.value.column, err.value.row) == ("t_s", missing_row)


def test_a_step_under_one_and_a_half_periods_is_jitter_not_a_hole():
    t = np.arange(100) / RATE_HZ
    t[50:] += 0.45 / RATE_HZ         # one step of 1.45 periods
    check_uniform_clock(t, RATE_HZ)
    t[50:] += 0.1 / RATE_HZ          # 1.55 periods
    with pytest.raises(TimestampError):
        check_uniform_clock(t, RATE_HZ)


def _frame(n=300, **columns):
    t = np.arange(n) / RATE_HZ
    data = {"t_s": t, "wz": np.sin(t), "vel_l": np.full(n, 0.5), "vel_r": np.full(n, 0.5),
            "cur_l": np.ones(n), "cur_r": np.ones(n)}
    data.update(columns)
    return pd.DataFrame(data)


@pytest.mark.parametrize("steady_only, column", [(False, "wz"), (True, "vel_r")])
def test_window_frame_refuses_a_column_of_booleans_naming_it(steady_only, column):
    # a mask was cut into windows of 0 and 1 (and, as a wheel speed, judged steady)
    frame = _frame(**{column: np.ones(300, bool)})
    with pytest.raises(DataFormatError) as err:
        window_frame(frame, ["wz"], WindowConfig(steady_only=steady_only))
    assert err.value.column == column


def test_window_frame_refuses_text_naming_the_column():
    with pytest.raises(DataFormatError) as err:     # pandas' bare ValueError
        window_frame(_frame(wz=np.array(["a"] * 300, dtype=object)), ["wz"], WindowConfig())
    assert err.value.column == "wz"
    with pytest.raises(ConfigError, match="channels"):     # len(None): a bare TypeError
        window_frame(_frame(), None, WindowConfig())


@pytest.mark.parametrize("column", ["vel_l", "cur_r"])
def test_add_derived_channels_refuses_booleans_and_text_naming_the_column(column):
    with pytest.raises(DataFormatError) as err:     # a mask gave vel_mean 0.75 m/s
        add_derived_channels(_frame(**{column: np.ones(300, bool)}))
    assert err.value.column == column
    with pytest.raises(DataFormatError) as err:
        add_derived_channels(_frame(**{column: np.array(["x"] * 300, dtype=object)}))
    assert err.value.column == column


def test_windows_of_valid_columns_are_unchanged_by_the_column_checks():
    frame = _frame(vel_l=np.arange(300) % 7, cur_l=np.linspace(0.0, 3.0, 300))   # int speeds
    X, t0, _, _, counts = window_frame(add_derived_channels(frame), ["wz", "vel_mean"],
                                       WindowConfig(steady_only=True, max_speed_std_m_s=5.0))
    assert X.shape == (3, 2, 100) and counts["dropped_unsteady"] == 0
    np.testing.assert_array_equal(X[1, 1], 0.5 * (np.arange(100, 200) % 7 + 0.5))
    np.testing.assert_array_equal(t0, [0.0, 2.0, 4.0])
