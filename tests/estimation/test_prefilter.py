"""Pre-filters: the noise level of a measurement row on bad input."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import EstimationError
from terrain.estimation import robust_noise_std


@pytest.mark.parametrize("rate_hz, window_s", [(np.nan, 0.5), (0.0, 0.5), (-5.0, 0.5),
                                               (100.0, np.nan), (100.0, 0.0), ("a", 0.5)])
def test_robust_noise_std_refuses_a_bad_rate_or_window(rate_hz, window_s):
    # a NaN rate raised "cannot convert float NaN to integer"; a rate of 0 or -5 Hz silently
    # used a 3-sample window and returned 0.0 for a constant signal
    with pytest.raises(EstimationError, match="rate_hz|window_s"):
        robust_noise_std(np.ones(10), rate_hz, window_s)


def test_robust_noise_std_of_no_samples_is_nan():
    # shapes (0,) and (0, 2) raised "cannot reshape array of size 0 into shape (0,newaxis)"
    assert np.isnan(robust_noise_std(np.zeros(0), 100.0))
    out = robust_noise_std(np.zeros((0, 2)), 100.0)
    assert out.shape == (2,) and np.isnan(out).all()
    rng = np.random.default_rng(0)
    noise = robust_noise_std(0.1 * rng.standard_normal((2000, 2)), 100.0, 0.5)
    np.testing.assert_allclose(noise, 0.1, rtol=0.1)
