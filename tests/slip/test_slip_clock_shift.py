"""The slip filter of a skid-steer run (terrain.slip.estimate.estimate_skid_steer_slip_run)
at its default rate reads the same run on a clock shifted by a day, or on an epoch clock, as
on the clock from 0. Its default rate was 1 / the median IMU step, which the clock's
rounding moves (100.0000000524 Hz at 1e5 s, 100.000095 Hz at 1.7e9 s); it is now the
estimators' one rule, terrain.estimation.runner.clock_rate_hz (est20), and this guards it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pipelines.validation.harness import simulate_husky
from terrain.run import TIME
from terrain.slip.estimate import estimate_skid_steer_slip_run


@pytest.fixture(scope="module")
def husky_run():
    return simulate_husky("ASPHALT", seed=4, duration_s=10.0, icr_expansion=1.5,
                          gyro_bias=0.01).run


def _shifted(run, shift_s: float):
    streams = {name: frame.assign(**{TIME: frame[TIME] + shift_s})
               for name, frame in run.streams.items()}
    return dataclasses.replace(run, streams=streams)


@pytest.mark.parametrize("shift_s", [1e5, 1.7e9])
@pytest.mark.parametrize("slip_model", ["ekf", "physics"])
def test_slip_filter_at_its_default_rate_ignores_a_clock_shift(husky_run, slip_model, shift_s):
    a = estimate_skid_steer_slip_run(husky_run, slip_model, lag="none")
    b = estimate_skid_steer_slip_run(_shifted(husky_run, shift_s), slip_model, lag="none")
    assert a.ekf.t_s.shape == b.ekf.t_s.shape
    np.testing.assert_allclose(b.ekf.t_s - shift_s, a.ekf.t_s, atol=1e-6)
    np.testing.assert_allclose(b.ekf.x, a.ekf.x, atol=1e-6)
    np.testing.assert_allclose(b.slip, a.slip, atol=1e-6)
