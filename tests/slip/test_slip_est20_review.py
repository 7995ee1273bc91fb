"""Review tests (est20): metamorphic relations of the slip baselines, odometry and physics slip.

Permuting independent inputs (terrain classes), mirroring left/right with the yaw sign
flipped, driving backward with the signs flipped, shifting the clock and splitting a run
in two must not change the answers beyond rounding.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import DataWarning, EstimationError
from terrain.slip.alignment import LagGate, estimate_lag, gated_lag
from terrain.slip.baselines import endo_turning_slip, observer_slip
from terrain.slip.core import skid_steer_side_slip, wheel_slip
from terrain.slip.odometry import dead_reckon
from terrain.slip.physics import physics_slip
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.vehicles import HUSKY


def _drive(seed: int, n: int):
    """Times, side rim speeds, slips, chi and lateral velocity of one random run."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 0.1, n))
    v = rng.normal(1.0, 0.6, (n, 2))
    slip = rng.uniform(-0.6, 0.6, (n, 2))
    return t, v, slip, rng.uniform(1.0, 3.0, n), rng.normal(0.0, 0.1, n)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 31), n=st.integers(2, 60))
def test_dead_reckon_mirror_backward_shift_and_split(seed, n):
    """Swapping the sides (lateral velocity negated) mirrors the path (y and yaw negated);
    negating speeds and slips drives it backward (x and yaw negated); a clock shift changes
    nothing; two halves composed in the first half's end frame are the whole run."""
    t, v, s, chi, lat = _drive(seed, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        pose = dead_reckon(t, v[:, 0], v[:, 1], 0.55, s[:, 0], s[:, 1], chi, lat)
        mirror = dead_reckon(t, v[:, 1], v[:, 0], 0.55, s[:, 1], s[:, 0], chi, -lat)
        back = dead_reckon(t, -v[:, 0], -v[:, 1], 0.55, -s[:, 0], -s[:, 1], chi, lat)
        shifted = dead_reckon(t + 3600.0, v[:, 0], v[:, 1], 0.55, s[:, 0], s[:, 1], chi, lat)
        k = n // 2
        head = dead_reckon(t[:k + 1], v[:k + 1, 0], v[:k + 1, 1], 0.55, s[:k + 1, 0],
                           s[:k + 1, 1], chi[:k + 1], lat[:k + 1])
        tail = dead_reckon(t[k:], v[k:, 0], v[k:, 1], 0.55, s[k:, 0], s[k:, 1], chi[k:],
                           lat[k:])
    np.testing.assert_allclose(mirror, pose * [1, -1, -1], atol=1e-9)
    np.testing.assert_allclose(back, pose * [-1, 1, -1], atol=1e-9)
    np.testing.assert_allclose(shifted, pose, atol=1e-7)
    x0, y0, yaw0 = head[-1]
    c, s0 = np.cos(yaw0), np.sin(yaw0)
    joined = np.column_stack([x0 + c * tail[:, 0] - s0 * tail[:, 1],
                              y0 + s0 * tail[:, 0] + c * tail[:, 1], yaw0 + tail[:, 2]])
    np.testing.assert_allclose(joined, pose[k:], atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 31), n=st.integers(1, 40), scale=st.sampled_from([3.6, 0.01]))
def test_side_slip_mirror_backward_and_units(seed, n, scale):
    """Side slip: swapped sides with the yaw rate negated swap the slips; all speeds
    negated negate them; speeds (and dead band) in other units leave them."""
    rng = np.random.default_rng(seed)
    rim = rng.normal(0.5, 0.8, (n, 2))
    v = rng.normal(0.5, 0.8, n)
    w = rng.normal(0.0, 1.0, n)
    s = skid_steer_side_slip(rim, v, w, 0.55)
    np.testing.assert_allclose(skid_steer_side_slip(rim[:, ::-1], v, -w, 0.55)[:, ::-1], s,
                               atol=1e-12)
    np.testing.assert_allclose(skid_steer_side_slip(-rim, -v, -w, 0.55), -s, atol=1e-12)
    np.testing.assert_allclose(skid_steer_side_slip(rim * scale, v * scale, w * scale, 0.55,
                                                    dead_band_m_s=0.05 * scale), s, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 31), n=st.integers(1, 40))
def test_endo_turning_slip_mirror_and_backward(seed, n):
    """Endo's ratio (seed 003 eq. 27): the mirrored turn swaps the sides' slip ratios; the
    same turn driven backward (speeds and yaw rate negated) keeps them (the ratio is
    relative to the rim speed)."""
    rng = np.random.default_rng(seed)
    v = rng.uniform(0.05, 1.5, (n, 2)) * rng.choice([-1.0, 1.0], (n, 2))
    w = rng.normal(0.0, 1.0, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        a = endo_turning_slip(v[:, 0], v[:, 1], w, 0.55)
        mirror = endo_turning_slip(v[:, 1], v[:, 0], -w, 0.55)
        back = endo_turning_slip(-v[:, 0], -v[:, 1], -w, 0.55)
    np.testing.assert_allclose(mirror[:, ::-1], a, atol=1e-9)
    np.testing.assert_allclose(back, a, atol=1e-12)


def test_observer_slip_mirror_clock_shift_and_heading_offset():
    """The seed 000 observer: mirrored (sides swapped, heading negated) its slips swap; a
    clock shift or a heading offset of 2 pi changes nothing."""
    rng = np.random.default_rng(3)
    n = 300
    t = np.cumsum(rng.uniform(0.02, 0.05, n))
    yaw = np.cumsum(rng.normal(0.0, 1.0, n) * 0.03)
    vl, vr = rng.uniform(0.2, 1.5, n), rng.uniform(0.2, 1.5, n)
    s = observer_slip(t, yaw, vl, vr, 0.275)
    np.testing.assert_allclose(observer_slip(t, -yaw, vr, vl, 0.275)[:, ::-1], s, atol=1e-12)
    np.testing.assert_allclose(observer_slip(t + 1e4, yaw, vl, vr, 0.275), s, atol=1e-8)
    np.testing.assert_allclose(observer_slip(t, yaw + 2 * np.pi, vl, vr, 0.275), s, atol=1e-9)


def test_physics_slip_saturation_flag_does_not_depend_on_the_order_of_tied_terrains():
    """Two terrains of equal probability: ``saturated`` (the most probable terrain's curve
    asked for its maximum or more) followed whichever was listed first, so
    {SNOW: .5, ASPHALT: .5} said saturated where {ASPHALT: .5, SNOW: .5} did not, for the
    same currents (the slips and stds agreed)."""
    cur = np.array([[2.0, 2.0], [8.0, 8.0], [15.0, 15.0], [30.0, 30.0]])
    rim = np.full(cur.shape, 0.5)
    a = physics_slip(HUSKY, {"SNOW": 0.5, "ASPHALT": 0.5}, cur, rim, np.zeros(4))
    b = physics_slip(HUSKY, {"ASPHALT": 0.5, "SNOW": 0.5}, cur, rim, np.zeros(4))
    np.testing.assert_array_equal(a.saturated, b.saturated)
    snow = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, np.zeros(4))
    asphalt = physics_slip(HUSKY, {"ASPHALT": 1.0}, cur, rim, np.zeros(4))
    # a tie is flagged where any of the tied curves is asked for its maximum
    np.testing.assert_array_equal(a.saturated, snow.saturated | asphalt.saturated)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 31), k=st.integers(2, 4))
def test_physics_slip_does_not_depend_on_the_order_of_the_terrain_classes(seed, k):
    """Terrain probabilities given in another order (ties included) give the same slip,
    interval and flags."""
    rng = np.random.default_rng(seed)
    names = list(rng.choice(TERRAIN_NAMES, k, replace=False))
    p = rng.choice([0.1, 0.2, 0.2, 0.5], (6, k))      # ties on purpose
    cur = rng.uniform(0.0, 30.0, (6, 2))
    rim = rng.uniform(-1.5, 1.5, (6, 2))
    pitch = rng.uniform(-0.2, 0.2, 6)
    probs = {name: p[:, i] for i, name in enumerate(names)}
    a = physics_slip(HUSKY, probs, cur, rim, pitch)
    b = physics_slip(HUSKY, dict(reversed(list(probs.items()))), cur, rim, pitch)
    for field in ("slip", "std", "lower", "upper", "mu"):
        np.testing.assert_allclose(getattr(b, field), getattr(a, field), atol=1e-9,
                                   err_msg=field)
    np.testing.assert_array_equal(b.saturated, a.saturated)


@pytest.mark.parametrize("slope", [0.3, 0.7, 1.0])
def test_lag_of_a_ramp_is_refused_as_having_no_transient(slope):
    """A steady ramp (a constant acceleration) has a constant derivative, no transient to
    align on, like a constant signal (refused); its derivative's rounding (1e-16 relative)
    was cross-correlated instead: a ramp 0.05 s behind a ramp came out 0.50 s behind at
    correlation 0.51, applied by a gate without the halves check."""
    t = np.arange(0.0, 20.0, 0.01)
    with pytest.raises(EstimationError, match="ref and sig is constant over"):
        estimate_lag(t, slope * t, t + 0.05, slope * t + 2.0)
    with pytest.raises(EstimationError, match="no transient"):
        gated_lag(t, slope * t, t + 0.05, slope * t + 2.0,
                  gate=LagGate(halves_tolerance_s=None))
    with pytest.raises(EstimationError, match=r"^sig is constant"):
        estimate_lag(t, np.sin(t), t, slope * t)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 31), lag=st.floats(-0.5, 0.5), shift=st.sampled_from([0.0, 1e3]),
       gain=st.sampled_from([1.0, -3.0, 0.01]))
def test_lag_swaps_sign_with_the_signals_and_ignores_clock_and_gain(seed, lag, shift, gain):
    """``sig`` behind ``ref`` by ``L`` is ``ref`` behind ``sig`` by ``-L``; a common clock
    shift and a common gain (units, sign) change nothing."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 15.0, 0.01)
    ref = np.convolve(np.cumsum(rng.normal(size=t.size)), np.ones(20) / 20, "same")
    ts = t + rng.uniform(-0.3, 0.3)
    sig = np.interp(ts - lag, t, ref)
    a = estimate_lag(t, ref, ts, sig)
    assert estimate_lag(ts, sig, t, ref).lag_s == pytest.approx(-a.lag_s, abs=1e-9)
    b = estimate_lag(t + shift, gain * ref, ts + shift, gain * sig)
    assert b.lag_s == pytest.approx(a.lag_s, abs=1e-6)
    assert b.correlation == pytest.approx(a.correlation, abs=1e-6)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 31), n=st.integers(1, 30))
def test_steered_wheel_slip_mirror_and_units(seed, n):
    """Four steered wheels (seed 001 eqs. 7.3-7.5): the mirrored vehicle (left and right
    wheels swapped, lateral velocity, yaw rate and steering negated) has the same slips on
    the swapped wheels; speeds in other units (dead band too) leave them."""
    rng = np.random.default_rng(seed)
    pos = np.array([[0.5, 0.4], [0.5, -0.4], [-0.5, 0.4], [-0.5, -0.4]])
    vx, vy, w = rng.normal(0.5, 0.5, n), rng.normal(0.0, 0.2, n), rng.normal(0.0, 0.5, n)
    delta, rim = rng.normal(0.0, 0.5, (n, 4)), rng.normal(0.5, 0.5, (n, 4))
    s = wheel_slip(rim, vx, vy, w, pos, delta)
    swap = [1, 0, 3, 2]
    np.testing.assert_allclose(wheel_slip(rim[:, swap], vx, -vy, -w, pos, -delta[:, swap]),
                               s[:, swap], atol=1e-12)
    np.testing.assert_allclose(wheel_slip(rim * 1e3, vx * 1e3, vy * 1e3, w * 1e3, pos, delta,
                                          dead_band_m_s=50.0), s, atol=1e-9)
