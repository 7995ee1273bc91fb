"""Review tests (est19): slip estimation defects found by targeted checks."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import EstimationError, TimeStepError
from terrain.slip.baselines import fit_pitch_slip, pitch_slip
from terrain.slip.estimate import estimate_skid_steer_slip_run


def test_skid_steer_slip_run_names_the_run_for_streams_that_do_not_overlap(steady_husky_run):
    """The slip-augmented filter of ``terrain estimate`` built its grid with make_grid too:
    'empty time span [10.0, 4.99] s', no run named."""
    outputs = {"physics": (np.array([1.0, 3.0]), np.zeros((2, 2)), np.full((2, 2), 0.05))}
    with pytest.raises(TimeStepError, match=r"run test/ASPHALT/00: the streams the filter "
                       r"reads do not overlap in time \('wheels' 0\.\.4\.99 s, 'imu' "
                       r"10\.\.14\.99 s\)"):
        estimate_skid_steer_slip_run(steady_husky_run(imu_shift_s=10.0), "physics",
                                     outputs=outputs, lag="none")
    est = estimate_skid_steer_slip_run(steady_husky_run(), "physics", outputs=outputs, lag="none")
    assert est.ekf.t_s[0] == 0.0 and est.slip.shape == (est.ekf.t_s.size, 2)


def test_pitch_slip_model_refuses_booleans():
    """A mask given for the pitch (or the slip) of seed 003 eq. 22 was fitted as values of 0
    and 1: fit_pitch_slip([True, False], [0.1, 0.2], ['A', 'A']) gave a slope of -0.1."""
    with pytest.raises(EstimationError, match="fit_pitch_slip: pitch_rad must hold numbers"):
        fit_pitch_slip([True, False], [0.1, 0.2], ["A", "A"])
    with pytest.raises(EstimationError, match="fit_pitch_slip: slip must hold numbers"):
        fit_pitch_slip([0.0, 0.1], np.array([True, False]), ["A", "A"])
    with pytest.raises(EstimationError, match="pitch_slip: pitch_rad must hold numbers"):
        pitch_slip({"A": (0.1, 1.0)}, np.array([True]), ["A"])
    coef = fit_pitch_slip([0.0, 0.1], [0.1, 0.2], ["A", "A"])
    assert coef["A"] == pytest.approx((0.1, 1.0))
    assert pitch_slip(coef, [0.05], ["A"]) == pytest.approx([0.15])
