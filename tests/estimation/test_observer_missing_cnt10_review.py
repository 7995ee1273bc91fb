"""Review tests (cnt10): the adaptive observer counts the samples it had to skip."""

from __future__ import annotations

import numpy as np

from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer


def test_the_samples_without_a_correction_are_counted():
    # before: a NaN heading or speed left a NaN error row, with no count of such rows
    t = np.arange(20) * 0.1
    pose = np.column_stack([np.zeros(20), np.zeros(20), np.zeros(20)])
    vr = np.full(20, 0.5)
    vl = np.full(20, 0.5)
    pose[3, 2] = np.nan          # heading missing
    vr[7] = np.inf               # speed not finite
    pose[9, 0] = np.nan          # position missing: read only with use_position
    res = run_adaptive_observer(t, pose, vr, vl, AdaptiveObserverSettings(use_position=True))
    assert res.missing_samples == 3
    res = run_adaptive_observer(t, pose, vr, vl, AdaptiveObserverSettings(use_position=False))
    assert res.missing_samples == 2
    assert run_adaptive_observer(t, np.zeros((20, 3)), np.full(20, 0.5), np.full(20, 0.5),
                                 AdaptiveObserverSettings()).missing_samples == 0
