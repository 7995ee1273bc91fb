"""Pre-filters: the noise level of a measurement row on bad input."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import EstimationError
from terrain.estimation import robust_noise_std


@pytest.mark.parametrize("rate_hz, window_s", [(np.nan, 0.5), (0.0, 0.5), (-5.0, 0.5),
                                               (100.0, np.nan), (100.0, 0.0), ("a", 0.5),
                                               (True, 0.5), ("100", 0.5), (100.0, True)])
def test_robust_noise_std_refuses_a_bad_rate_or_window(rate_hz, window_s):
    # a NaN rate raised "cannot convert float NaN to integer"; a rate of 0 or -5 Hz silently
    # used a 3-sample window and returned 0.0 for a constant signal; True passed as 1 Hz
    # (or a 1 s window) and the text "100" as 100 Hz through float()
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


def test_ema_weights_the_previous_output_by_alpha_as_eq_6_12():
    """``z_new = alpha z_prev + (1 - alpha) z_raw`` (seed 001 eq. 6.12, alpha = 0.1: light
    smoothing). With alpha = 0.5 the two weights are equal, so only an asymmetric alpha
    tells the convention: a step 0 -> 10 reaches 9 after one sample with alpha = 0.1."""
    from terrain.estimation import ema_filter
    np.testing.assert_allclose(ema_filter(np.array([0.0, 10.0, 10.0]), 0.1), [0.0, 9.0, 9.9])
    np.testing.assert_allclose(ema_filter(np.array([0.0, 10.0, 10.0]), 0.75),
                               [0.0, 2.5, 4.375])
    np.testing.assert_array_equal(ema_filter(np.array([1.0, 5.0]), 0.0), [1.0, 5.0])
    with pytest.raises(EstimationError, match="alpha"):
        ema_filter(np.array([1.0, 5.0]), 1.0)        # would freeze at the first sample


def test_robust_noise_std_needs_a_window_of_finite_samples():
    # 40 finite samples at 100 Hz cannot fill a 0.5 s (51-sample) window: NaN, not a number
    # from a moving average that is all edge
    rng = np.random.default_rng(1)
    col = rng.standard_normal(200)
    col[40:] = np.nan
    assert np.isnan(robust_noise_std(col, 100.0, 0.5))
    assert np.isfinite(robust_noise_std(col[:40], 100.0, 0.3))      # 31-sample window
