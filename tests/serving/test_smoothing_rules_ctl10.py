"""Review pass ctl10 of the forward filter's skips and the live stuck-sensor rule."""

from __future__ import annotations

import numpy as np
import pandas as pd

from terrain.serving.smoothing import ForwardFilter, SmoothingConfig, predict_steps


def test_one_class_filter_skips_without_dividing_by_zero():
    """With one class the prediction has no other class to move to (lambda of
    :func:`predict_steps` would divide by K - 1 = 0): p stays [1]."""
    assert predict_steps(np.array([1.0]), 5, 0.0).tolist() == [1.0]
    filt = ForwardFilter(1, 0.5, SmoothingConfig())
    assert filt.update(np.array([1.0]))[0] == 0
    filt.skip(7)
    assert filt.p.tolist() == [1.0] and filt.current == 0


def test_skipping_zero_hops_without_the_filter_keeps_the_last_probabilities():
    """``skip(0)`` is no step at all: without the filter the last window's probabilities
    stay (``skip(n >= 1)`` forgets them, as ``update(None)`` does)."""
    filt = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=None))
    q = np.array([0.7, 0.2, 0.1])
    filt.update(q)
    filt.skip(0)
    np.testing.assert_array_equal(filt.p, q)
    filt.skip(1)
    np.testing.assert_allclose(filt.p, np.full(3, 1 / 3))


def test_stuck_watch_counts_a_chunk_inside_the_stretch_sample_by_sample():
    """A gyro stretch of exactly STUCK_MIN_SAMPLES (10) samples at 8 Hz (1.125 s >= 1 s) is
    stuck; fed in chunks of two, whole chunks lie inside the stretch and each of their
    samples counts (one short and the stretch would be missed)."""
    from terrain.io.plausibility import STUCK_MIN_SAMPLES, stuck_stretches
    from terrain.run import TIME
    from terrain.serving.rules import StuckWatch

    rng = np.random.default_rng(3)
    n_before, n_after = 6, 6
    t = np.arange(n_before + STUCK_MIN_SAMPLES + n_after) * 0.125
    wx = rng.normal(size=len(t))
    wx[n_before:n_before + STUCK_MIN_SAMPLES] = 0.25
    values = wx[:, None]
    want = stuck_stretches({"imu": pd.DataFrame({TIME: t, "wx": wx})})
    assert want == {"imu.wx": [[t[n_before], t[n_before + STUCK_MIN_SAMPLES - 1]]]}
    watch = StuckWatch("imu", ("wx",))
    for a in range(0, len(t), 2):
        watch.update(t[a:a + 2], values[a:a + 2])
    assert [list(s) for s in watch.ended[0]] == want["imu.wx"]


def test_a_filter_without_a_smoothing_config_is_a_config_error():
    """``ForwardFilter(3, 0.5, None)`` raised AttributeError 'NoneType' object has no
    attribute 'dwell_s' (a dict of settings the same)."""
    import pytest

    from terrain.errors import ConfigError

    for config in (None, {"dwell_s": 5.0}):
        with pytest.raises(ConfigError, match="SmoothingConfig"):
            ForwardFilter(3, 0.5, config)


def test_a_window_of_booleans_or_text_is_refused_not_read_as_probabilities():
    """A boolean mask passed as a window's probabilities was read as certainty
    ([True, False, False] decided class 0 at 0.98); text raised numpy's bare 'ufunc isfinite
    not supported'. Both are DataFormatErrors naming the dtype, with or without the filter,
    and nothing is folded in."""
    import pytest

    from terrain.errors import DataFormatError

    for config in (SmoothingConfig(), SmoothingConfig(dwell_s=None)):
        filt = ForwardFilter(3, 0.5, config)
        for q in (np.array([True, False, False]), [False, True, False],
                  np.array(["0.2", "0.3", "0.5"])):
            with pytest.raises(DataFormatError, match=r"real numbers.*(bool|<U3)"):
                filt.update(q)
        np.testing.assert_array_equal(filt.p, np.full(3, 1 / 3))
        assert filt.current is None
        assert filt.update([0, 1, 0])[0] == 1     # integers are numbers


def test_forward_step_is_rabiners_recursion_with_a_row_stochastic_transition_matrix():
    """Rabiner (1989) eq. 20 normalised: ``alpha_k ∝ (alpha_{k-1} A) * b_k`` with
    ``A = (1 - p) I + p (J - I) / (K - 1)`` (rows sum to 1) and ``b = max(q, floor)**power``;
    :func:`predict_steps` is ``p A**n``; every filtered distribution sums to 1."""
    from terrain.serving.smoothing import PROBA_FLOOR, forward_step

    rng = np.random.default_rng(7)
    for k in (2, 3, 5):
        for p_switch in (0.0, 0.05, (k - 1) / k):
            a = (1 - p_switch) * np.eye(k) + p_switch * (1 - np.eye(k)) / (k - 1)
            np.testing.assert_allclose(a.sum(axis=1), 1.0)
            p = rng.dirichlet(np.ones(k))
            for _ in range(20):
                q = rng.dirichlet(np.ones(k) * 0.3)
                alpha = (p @ a) * np.maximum(q, PROBA_FLOOR) ** 0.5
                got = forward_step(p, q, p_switch, 0.5)
                np.testing.assert_allclose(got, alpha / alpha.sum(), rtol=1e-12)
                assert abs(got.sum() - 1.0) < 1e-12
                p = got
            np.testing.assert_allclose(predict_steps(p, 6, p_switch),
                                       p @ np.linalg.matrix_power(a, 6), atol=1e-12)
