"""Convergence times of the validation harness (:mod:`pipelines.validation.harness`)."""

from __future__ import annotations

import numpy as np

from pipelines.validation.harness import _conv_time


def test_convergence_time_is_after_the_last_sample_over_the_tolerance():
    t = np.array([10.0, 11.0, 12.0, 13.0, 14.0])
    assert _conv_time(t, np.array([0.2, 0.01, 0.3, 0.01, 0.02])) == 12.0
    assert _conv_time(t, np.full(5, 0.01)) == 10.0          # below from the first sample
    assert np.isnan(_conv_time(t[:0], t[:0]))               # no steady-turn sample


def test_an_error_still_over_the_tolerance_at_the_end_never_converged():
    # the last steady-turn sample over 5 %: the error never stays below it, which read as
    # convergence at that sample (observer eta, random ASPHALT seed 5: 59.98 s of 60 s)
    t = np.array([10.0, 11.0, 12.0, 13.0])
    assert _conv_time(t, np.array([0.01, 0.01, 0.01, 0.2])) == np.inf
    assert _conv_time(t, np.array([0.2, 0.2, 0.2, 0.2])) == np.inf
