"""Review io4: tests that kill hand mutants of terrain.errors, terrain.run and the
interpolated-sample count of terrain.io.align."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError, DataFormatError, config_fraction, config_seed
from terrain.io.align import interpolated_mean_count
from terrain.run import step_index


def test_a_sample_a_nanosecond_after_a_step_belongs_to_that_step():
    # t - 1e-9 lands exactly on the step 0.0: the first step at or after it is step 0,
    # not step 1 (searchsorted side="right" gave 1)
    np.testing.assert_array_equal(step_index(np.array([0.0, 1.0]), [1e-9, 0.0]), [0, 0])


def test_seed_zero_is_a_seed_and_a_negative_one_is_not():
    config_seed("seed", 0)
    config_seed("seed", 0.0)
    with pytest.raises(ConfigError, match="seed must be an integer >= 0"):
        config_seed("seed", -1)


def test_a_fraction_of_one_is_accepted_and_more_is_not():
    config_fraction("traction_peak", fraction=1.0)
    with pytest.raises(ConfigError, match=r"traction_peak: fraction must be in \(0, 1\]"):
        config_fraction("traction_peak", fraction=1.0000001)


def test_a_data_error_names_the_file_line_not_the_data_row_when_both_are_known():
    err = DataFormatError("bad value", "imu_00.csv", "wx", row=3, line=5)
    assert str(err) == "bad value (file imu_00.csv, column 'wx', line 5)"
    assert (err.row, err.line) == (3, 5)
    err = DataFormatError("bad value", "imu_00.csv", "wx", row=3)
    assert str(err) == "bad value (file imu_00.csv, column 'wx', data row 3 (0-based))"


def test_interpolated_mean_count_of_one_point_between_two_samples_by_hand():
    # one clock point, a slower stream at phase p of a step: hat weights p and 1 - p, so
    # 1 / sum w^2 = 1 / (p^2 + (1 - p)^2). Phases are the midpoints of n_phases bins:
    # n_phases=1 -> p = 0.5: 2; n_phases=2 -> p = 0.25, 0.75: 1 / 0.625 = 1.6
    assert interpolated_mean_count(1, 50.0, 10.0, n_phases=1) == pytest.approx(2.0)
    assert interpolated_mean_count(1, 50.0, 10.0, n_phases=2) == pytest.approx(1.6)
    # the uniform average tends to 1 / (2/3) = 1.5
    assert interpolated_mean_count(1, 50.0, 10.0, n_phases=256) == pytest.approx(1.5, abs=1e-4)


def test_a_run_built_in_memory_is_not_named_as_a_blank_file():
    # Run.source defaults to "": every error about such a run read "(file , column 't_s')"
    err = DataFormatError("stream 'imu' has no samples", "", "t_s")
    assert str(err) == "stream 'imu' has no samples (column 't_s')"
    assert str(DataFormatError("no overlap", "")) == "no overlap"
    assert err.path == ""


@pytest.mark.parametrize("args", [(2.5, 50.0, 10.0), (True, 50.0, 10.0), (10, True, 5.0),
                                  (10, 50.0, float("inf")), (10, 50.0, float("nan")),
                                  (0, 50.0, 10.0), (10, 50.0, 10.0, 0)])
def test_interpolated_mean_count_refuses_a_window_length_or_rate_that_is_not_one(args):
    # 2.5 samples gave 1.607 and True (as 1 sample) 1.5 without a word
    with pytest.raises(ConfigError, match="interpolated_mean_count"):
        interpolated_mean_count(*args)
