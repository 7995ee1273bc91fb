"""The decision-time matching of benchmarks/stream_multiscale.py."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "stream_multiscale.py"


def test_one_second_decisions_are_matched_to_the_two_second_ones():
    at_times = runpy.run_path(str(SCRIPT))["at_times"]
    # 1 s windows decide from t = 1 s, 2 s windows from t = 2 s, both every 0.5 s; the grid
    # carries float rounding; the 1 s classifier skipped t = 3.0 s (say a gap it flagged
    # on its own clock)
    t1 = np.array([1.0, 1.5, 2.0, 2.5, 3.5, 4.0]) + 1e-12
    p1 = np.arange(12.0).reshape(6, 2)
    t2 = np.array([2.0, 2.5, 3.0, 3.5, 4.0, 4.5])
    got = at_times(t1, p1, t2)
    np.testing.assert_array_equal(got[[0, 1, 3, 4]], p1[[2, 3, 4, 5]])
    assert np.isnan(got[[2, 5]]).all()  # no 1 s decision at 3.0 s, none after 4.0 s
