"""The audit's low-pass and lag-drift helpers refuse settings they cannot use in the
project's words (stop 92; from the left-alone list)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.audit.replay import lowpass
from terrain.audit.timing import LagTrack
from terrain.errors import ConfigError


@pytest.mark.parametrize("rate_hz, cutoff_hz", [(100.0, 0.0), (100.0, -2.0), (0.0, 5.0),
                                                (100.0, float("nan")), (True, 5.0),
                                                (100.0, float("inf"))])
def test_lowpass_refuses_a_cut_off_or_rate_it_cannot_use(rate_hz, cutoff_hz):
    with pytest.raises(ConfigError, match="lowpass"):
        lowpass(np.zeros(50), rate_hz, cutoff_hz)


def test_lowpass_keeps_a_constant_and_removes_a_fast_sine():
    t = np.arange(500) / 100.0
    fast = np.sin(2 * np.pi * 30.0 * t)
    out = lowpass(2.0 + fast, 100.0, 2.0)
    np.testing.assert_allclose(out[50:-50], 2.0, atol=0.01)


def test_drift_needs_a_real_span():
    track = LagTrack(np.array([0.0, 30.0, 60.0]), np.array([0.1, 0.2, 0.3]),
                     np.ones(3), 3)
    assert track.drift_s_per_min() == pytest.approx(0.2)
    assert np.isnan(track.drift_s_per_min(min_span_s=61.0))
    for bad in (float("nan"), -1.0, True):
        with pytest.raises(ConfigError, match="min_span_s"):
            track.drift_s_per_min(min_span_s=bad)
