"""Review tests (est11): what the run summary says of samples holding a non-finite value."""

from __future__ import annotations

import numpy as np

from terrain.estimation.runner import SensorSamples, run_filter
from terrain.estimation.skid_steer import SkidSteerModel
from terrain.slip.estimate import RunEstimate


def test_a_sample_with_one_non_finite_side_is_not_called_skipped():
    # before: "non-finite samples skipped {'wheels': 2}" while one of the two, with only
    # vel_l NaN, was used for its vel_r row (counts: used 9 + non_finite 2 of 10 samples)
    t = np.arange(10) * 0.1
    w = np.full((10, 2), 0.5)
    w[3, 0] = np.nan                 # one side: its vel_r row is still used
    w[6] = np.nan                    # both sides: the sample is skipped
    ekf = run_filter(SkidSteerModel(), t, {"wheels": SensorSamples(t, w)})
    c = ekf.counts["wheels"]
    assert (c["samples"], c["non_finite"], c["used"]) == (10, 2, 9)
    est = RunEstimate("test/ASPHALT/00", "husky", ekf, np.zeros((10, 2)), ("slip_1", "slip_2"))
    text = est.summary()
    assert "non-finite samples skipped" not in text
    assert "samples holding a non-finite value (those values skipped) {'wheels': 2}" in text
