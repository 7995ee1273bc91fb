"""terrain.run.Run: metadata and streams of one drive."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError, MissingColumnError, NonFiniteError
from terrain.run import Run


def test_a_run_without_samples_lasts_zero_seconds():
    # max() over no non-empty frame raised a bare "max() arg is an empty sequence"
    empty = pd.DataFrame({"t_s": [], "vel_l": []})
    assert Run("sim/X/00", "sim", None, {"wheels": empty}).duration_s == 0.0
    assert Run("sim/X/01", "sim", None, {}).duration_s == 0.0
    two = pd.DataFrame({"t_s": [1.0, 3.5]})
    assert Run("sim/X/02", "sim", None, {"wheels": two}).duration_s == 2.5


def test_duration_is_the_wheel_streams_and_else_the_longest_streams():
    imu = pd.DataFrame({"t_s": [0.0, 30.0]})
    wheels = pd.DataFrame({"t_s": [2.0, 12.0]})
    assert Run("r/X/00", "r", None, {"imu": imu, "wheels": wheels}).duration_s == 10.0
    cam = pd.DataFrame({"t_s": [5.0, 9.0]})
    assert Run("r/X/01", "r", None, {"cam": cam, "imu": imu}).duration_s == 30.0


def test_rate_is_one_over_the_median_step():
    # steps of 0.01 s with one 2 s gap and one doubled step: the median ignores them
    t = np.concatenate([np.arange(0.0, 1.0, 0.01), [3.0, 3.02], 3.02 + np.arange(1, 50) * 0.01])
    run = Run("r/X/00", "r", None, {"imu": pd.DataFrame({"t_s": t})})
    assert run.rate_hz("imu") == pytest.approx(100.0)


def test_require_columns_names_the_run_stream_file_and_missing_columns():
    frame = pd.DataFrame({"t_s": [0.0], "vel_l": [0.0]})
    run = Run("borealtc/SNOW/03", "borealtc", "SNOW", {"wheels": frame}, source="a/b.csv")
    assert run.require_columns("wheels", ["vel_l"]) is frame
    with pytest.raises(MissingColumnError) as err:
        run.require_columns("wheels", ["vel_l", "cur_l", "cur_r"])
    assert str(err.value).startswith("run borealtc/SNOW/03: stream 'wheels' lacks columns "
                                     "['cur_l', 'cur_r']")
    assert "a/b.csv" in str(err.value) and "cur_l" in str(err.value)
    with pytest.raises(MissingColumnError, match=r"lacks columns \['t_s'\]"):
        Run("r/X/00", "r", None, {"imu": pd.DataFrame({"ax": [1.0]})}).require_columns(
            "imu", ["ax"])


@pytest.mark.parametrize("column, row", [("t_s", 2), ("vel_l", 1), ("vel_r", None)])
def test_require_finite_names_the_first_non_finite_value_of_time_and_the_columns(column, row):
    # t_s is checked before the named columns (an integrator steps on it); vel_r is not
    # named, so its inf passes
    frame = pd.DataFrame({"t_s": [0.0, 0.1, 0.2, 0.3], "vel_l": [0.5] * 4,
                          "vel_r": [0.5, np.inf, 0.5, 0.5]})
    if row is not None:
        frame.loc[row, column] = np.nan
        frame.loc[row + 1, column] = np.inf
    run = Run("r/X/00", "r", None, {"wheels": frame}, source="w.csv")
    if row is None:
        run.require_finite("wheels", ["vel_l"])
        return
    with pytest.raises(NonFiniteError, match=rf"2 non-finite value\(s\) in wheels column "
                                             rf"'{column}', first at row {row}") as err:
        run.require_finite("wheels", ["vel_l"])
    assert (err.value.column, err.value.row, err.value.path) == (column, row, "w.csv")


def test_a_sample_belongs_to_the_first_step_at_or_after_it_within_a_nanosecond():
    from terrain.run import step_index

    grid = np.array([0.0, 0.1, 0.2])
    t = [0.1 - 1e-12, 0.1, 0.1 + 1e-12, 0.1 + 2e-9, 0.05, 0.25]
    assert step_index(grid, t).tolist() == [1, 1, 1, 2, 1, 3]
    assert step_index(grid, t, clip=True).tolist() == [1, 1, 1, 2, 1, 2]


def test_times_out_of_order_strict_or_letting_a_repeat_pass():
    from terrain.run import times_out_of_order

    t = [0.0, 0.1, 0.1, 0.05, np.nan, 0.3, np.inf]
    assert times_out_of_order(t).tolist() == [2, 3, 4, 6]
    assert times_out_of_order(t, strict=False).tolist() == [3, 4, 6]
    assert times_out_of_order([]).tolist() == []


@pytest.mark.parametrize("t", [[], [2.0]])
def test_the_rate_of_a_stream_of_fewer_than_two_samples_is_an_error_naming_it(t):
    # the median of no step was NaN, returned as the rate without a word (the slip
    # features then said "interpolated_mean_count needs ... rates > 0, got ..., nan")
    run = Run("r/X/00", "r", None, {"wheels": pd.DataFrame({"t_s": t})}, source="pro_00.csv")
    with pytest.raises(DataFormatError, match=r"run r/X/00: stream 'wheels' has "
                       rf"{len(t)} sample\(s\)[^(]*\(file pro_00.csv, column 't_s'\)"):
        run.rate_hz("wheels")


def test_a_row_after_an_infinite_time_is_not_counted_again():
    """The docstring's rule: a row after a non-finite time is not counted again. After NaN
    it held (NaN compares False) and after -inf (1 - -inf = inf > 0), but after +inf the
    step 1 - inf = -inf counted the in-order row 2 as going back: [0, inf, 1, 2] gave rows
    [1, 2], "2 such rows" for one bad time."""
    from terrain.run import times_out_of_order

    for bad in (np.nan, np.inf, -np.inf):
        for strict in (True, False):
            assert times_out_of_order([0.0, bad, 1.0, 2.0], strict).tolist() == [1]
    assert times_out_of_order([0.0, np.inf, np.inf, 3.0, 2.0]).tolist() == [1, 2, 4]
    assert times_out_of_order([0.0, 2.0, 1.0, 3.0]).tolist() == [2]


@pytest.mark.parametrize("t", [[0.0, 0.0, 0.0], [0.0, -0.01, -0.02], [0.0, np.nan, np.nan],
                               [0.0, np.inf]])
def test_the_rate_of_a_stream_whose_times_break_the_contract_is_an_error_naming_it(t):
    # a Run built in memory is not checked: repeated times gave a rate of inf Hz, times
    # going back -100 Hz, NaN times NaN and an infinite time 0 Hz, each returned as a rate
    run = Run("r/X/00", "r", None, {"wheels": pd.DataFrame({"t_s": t})}, source="pro_00.csv")
    with pytest.raises(DataFormatError, match=r"run r/X/00: stream 'wheels' has no positive "
                       r"finite median time step .*\(file pro_00.csv, column 't_s'"):
        run.rate_hz("wheels")
