"""Review io9 of terrain.io.align: short finite runs in a filtered stream, the usual steps
a caller passes."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.io.align import align_arrays


def test_two_finite_samples_between_nans_are_filtered_with_one_sample_of_padding():
    # the module's example: two samples of a 30 Hz tone at 100 Hz, 0.296 and 0.817,
    # filtered with one sample of padding become 0.196 and 0.283; here they are a run of
    # finite samples between two NaNs of a 100 Hz stream on a 50 Hz grid, filtered on
    # their own (leaving a 2-sample run unfiltered let 30 Hz through onto the grid)
    t = np.arange(40) * 0.01
    v = np.sin(2 * np.pi * 3 * t)[:, None]
    v[10] = v[13] = np.nan
    v[11], v[12] = 0.296, 0.817
    out = align_arrays([t], [v], np.array([0.11, 0.12]), 50.0)
    np.testing.assert_allclose(out[:, 0], [0.196, 0.283], atol=1e-3)
    # a single finite sample between NaNs is kept as it is
    v[12] = np.nan
    v[11] = 0.296
    assert align_arrays([t], [v], np.array([0.11]), 50.0)[0, 0] == 0.296


@pytest.mark.parametrize("steps, match", [
    ([0.0], r"align_arrays.steps_s\[0\] must be a finite value > 0, got 0.0"),
    ([float("nan")], r"steps_s\[0\] must be a finite value > 0, got nan"),
    ([-0.01], r"steps_s\[0\] must be a finite value > 0"),
    ([0.01, 0.01], r"one step per stream: 1 stream\(s\), 2 step\(s\)"),
])
def test_a_step_that_is_not_a_positive_time_is_refused(steps, match):
    # a usual step of 0 was a bare ZeroDivisionError, NaN made no step a gap and switched
    # the anti-alias filter off without a word (the samples' median: 0.01 s, 100 Hz)
    from terrain.errors import ConfigError
    t = np.arange(40) * 0.01
    v = np.sin(2 * np.pi * 30 * t)[:, None]
    with pytest.raises(ConfigError, match=match):
        align_arrays([t], [v], np.array([0.1, 0.12]), 50.0, steps_s=steps)


def test_values_that_do_not_match_their_timestamps_are_refused():
    # 20 values for 40 timestamps were read as a stream of 20 samples (0.7 s got the 20th
    # value, 19.0, held past 0.38 s), a second stream without values was left out
    from terrain.errors import ConfigError
    t = np.arange(40) * 0.02
    v = np.arange(20.0)[:, None]
    with pytest.raises(ConfigError, match=r"stream 0: 20 row\(s\) of values for 40 "
                                          r"timestamp\(s\)"):
        align_arrays([t], [v], np.array([0.1, 0.7]), 50.0)
    with pytest.raises(ConfigError, match=r"2 timestamp array\(s\) and 1 value array"):
        align_arrays([t, t], [np.ones((40, 1))], np.array([0.1, 0.7]), 50.0)
    with pytest.raises(ConfigError, match=r"stream 0: values of shape \(40,\)"):
        align_arrays([t], [np.ones(40)], np.array([0.1, 0.7]), 50.0)
