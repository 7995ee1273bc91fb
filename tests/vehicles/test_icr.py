"""The single least-squares fit of the ICR expansion factor chi (terrain.vehicles.icr)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.vehicles.icr import icr_expansion_factor, inverse_icr_factor


@pytest.mark.parametrize("chi", [1.0, 1.5, 2.1])
def test_fit_recovers_chi_of_a_noisy_skid_steer(chi):
    rng = np.random.default_rng(3)
    x = rng.uniform(-0.8, 0.8, 5000)                  # commanded (v_R - v_L)/B, rad/s
    wz = x / chi + rng.normal(0.0, 0.02, x.size)      # gyro
    assert icr_expansion_factor(wz, x) == pytest.approx(chi, rel=0.01)
    assert inverse_icr_factor(wz, x) == pytest.approx(1.0 / chi, rel=0.01)
    # the two forms are reciprocal without floor
    assert icr_expansion_factor(wz, x) * inverse_icr_factor(wz, x) == pytest.approx(1.0)


def test_dug_in_vehicle_has_infinite_chi_and_floor_pulls_gain_to_zero():
    x = np.full(50, 0.5)
    assert icr_expansion_factor(np.zeros(50), x) == np.inf
    assert icr_expansion_factor(-x, x) == np.inf      # turning against the command
    tiny = np.full(50, 1e-3)
    assert abs(inverse_icr_factor(tiny / 1.5, tiny, 0.05)) < 1e-3


def test_batched_windows_and_shape_check():
    x = np.tile(np.linspace(-0.5, 0.5, 40), (3, 1))
    gains = inverse_icr_factor(x / np.array([[1.2], [1.5], [2.0]]), x)
    np.testing.assert_allclose(gains, [1 / 1.2, 1 / 1.5, 1 / 2.0])
    with pytest.raises(ValueError, match="shape"):
        icr_expansion_factor(np.zeros(3), np.zeros(4))


def test_arrays_of_different_shapes_are_a_shape_error():
    """icr_expansion_factor raised a bare ValueError on a shape mismatch, inverse_icr_factor
    and chi_from_truth NumPy's "operands could not be broadcast" ValueError, and
    chi_from_truth an IndexError for a yaw rate of another length. Each is now the
    project's ShapeError naming the shapes."""
    from terrain.errors import ShapeError
    from terrain.vehicles.icr import chi_from_truth
    three, four = np.ones(3), np.ones(4)
    with pytest.raises(ShapeError, match=r"\(3,\).*\(4,\)"):
        icr_expansion_factor(three, four)
    with pytest.raises(ShapeError, match=r"\(3,\).*\(4,\)"):
        inverse_icr_factor(three, four)
    with pytest.raises(ShapeError, match=r"\(3,\).*\(4,\)"):
        chi_from_truth(three, four, three, 0.5)
    with pytest.raises(ShapeError, match=r"\(3,\).*\(4,\)"):
        chi_from_truth(three, three, four, 0.5)
    assert chi_from_truth(three, 2 * three, three, 0.5) == pytest.approx(2.0)


def test_a_missing_sample_gives_an_unknown_chi_not_a_dug_in_vehicle():
    """A NaN yaw rate (a gyro dropout) made sum(x y) NaN, and ``NaN > 0`` is False, so
    icr_expansion_factor returned inf: the answer it reserves for a vehicle that does not
    turn the commanded way (dug in). An unknown chi is NaN."""
    x = np.linspace(0.1, 0.8, 50)
    wz = x / 1.5
    wz[7] = np.nan
    assert np.isnan(icr_expansion_factor(wz, x))
    assert np.isnan(icr_expansion_factor(x / 1.5, np.where(x > 0.5, np.nan, x)))
    assert icr_expansion_factor(np.zeros(50), x) == np.inf          # still dug in


@pytest.mark.parametrize("track_m", [0.0, -0.5, float("nan"), float("inf")])
def test_chi_from_truth_refuses_a_track_that_is_not_a_finite_length(track_m):
    from terrain.errors import ConfigError
    from terrain.vehicles.icr import chi_from_truth

    # a negative track turned chi 1.6 into -1.6 and 0 into NaN, without a word
    yaw = np.array([0.5, 0.5])
    with pytest.raises(ConfigError, match="chi_from_truth.track_m must be a finite value > 0"):
        chi_from_truth(np.array([-0.2, -0.2]), np.array([0.2, 0.2]), yaw, track_m)


def test_chi_from_truth_fits_left_and_right_turns_and_skips_slow_samples():
    from terrain.vehicles.icr import chi_from_truth
    track, chi = 0.55, 1.6
    w = np.array([0.5, -0.5, 0.8, -0.3, 0.05, 0.0])
    left = np.full(6, 0.4) - 0.5 * chi * track * w
    right = np.full(6, 0.4) + 0.5 * chi * track * w
    right[4] += 0.3                     # slower than 0.1 rad/s: left out of the fit
    assert chi_from_truth(left, right, w, track) == pytest.approx(chi, rel=1e-12)
    # right turns alone give the same chi (|yaw rate| selects the samples, not its sign)
    neg = w < -0.1
    assert chi_from_truth(left[neg], right[neg], w[neg], track) == pytest.approx(chi, rel=1e-12)
    assert np.isnan(chi_from_truth(left[4:], right[4:], w[4:], track))
