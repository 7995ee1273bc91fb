"""Encoder-lag alignment: sub-sample refinement, overlap, guards and the halves check."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError, EstimationError
from terrain.slip import estimate_lag, gated_lag

T = np.arange(0, 40, 0.01)
STEPS = (np.clip(T - 2.0, 0, 1) + 0.5 * np.clip(T - 8.0, 0, 1) * (T < 12)
         - 0.7 * np.clip(T - 25.0, 0, 1) + 0.4 * np.clip(T - 31.0, 0, 1) * (T < 35))


def test_a_lag_between_grid_samples_is_refined_by_the_parabola_in_both_directions():
    # 0.375 s lies half-way between two 10 ms grid samples: the parabola through the peak
    # and its neighbours finds it; the nearest grid lag alone is 5 ms off
    for planted in (0.375, -0.375, 0.2525):
        est = estimate_lag(T, STEPS, T, np.interp(T - planted, T, STEPS))
        assert est.lag_s == pytest.approx(planted, abs=0.0015)


def test_a_drifting_speed_does_not_pull_the_lag_towards_zero():
    # a steady acceleration is a constant derivative: removed before the correlation
    ref = STEPS + 5.0 * T        # a drift five times steeper than the transients
    est = estimate_lag(T, ref, T, np.interp(T - 0.37, T, ref))
    assert est.lag_s == pytest.approx(0.37, abs=0.01)
    assert est.correlation > 0.8


def test_the_grid_covers_only_the_overlap_of_the_two_streams():
    late = T >= 10.0             # the signal starts 10 s after the reference
    sig = np.interp(T - 0.37, T, STEPS)
    est = estimate_lag(T, STEPS, T[late], sig[late])
    assert est.n_samples == int(np.floor((T[-1] - 10.0) * 100.0)) + 1
    assert est.lag_s == pytest.approx(0.37, abs=0.01)
    with pytest.raises(EstimationError, match="overlap"):      # disjoint streams
        estimate_lag(T[T < 15], STEPS[T < 15], T[T > 25], STEPS[T > 25])


def test_an_overlap_under_four_times_the_searched_lag_is_too_short():
    # 2.99 s of overlap: 300 grid samples, under 4 x 100 for lags of up to 1 s
    short = T < 3.0
    with pytest.raises(EstimationError, match="too short"):
        estimate_lag(T[short], STEPS[short], T[short], STEPS[short], max_lag_s=1.0)
    # the same overlap searched up to 0.5 s is enough
    assert estimate_lag(T[short], STEPS[short], T[short], STEPS[short],
                        max_lag_s=0.5).n_samples == 300


def test_fewer_than_20_finite_samples_are_refused_whatever_the_grid():
    t = np.arange(0.0, 10.0, 1.0)            # 10 samples over 9 s: a 901-sample grid
    with pytest.raises(EstimationError, match="fewer than 20 finite samples"):
        estimate_lag(t, np.sin(t), t, np.cos(t))


def test_a_search_of_one_grid_step_is_allowed():
    est = estimate_lag(T, STEPS, T, STEPS, max_lag_s=0.01)
    assert abs(est.lag_s) <= 0.01
    # half a grid step, the least the docstring allows, searches one step (Python's round()
    # takes 0.5 to 0, and refused it as "under half a grid step")
    est = estimate_lag(T, STEPS, T, np.interp(T - 0.01, T, STEPS), max_lag_s=0.005)
    assert est.lag_s == pytest.approx(0.01, abs=0.002)
    # 12.5 steps search 13 (round() gave 12): 50 samples are then under four times the
    # searched lags (52) and refused, where 12 steps (48) pass
    t, x = np.arange(50) * 0.01, np.clip(np.arange(50) * 0.01 - 0.2, 0.0, 0.1)
    assert estimate_lag(t, x, t, x, max_lag_s=0.12).n_samples == 50
    with pytest.raises(EstimationError, match="too short to estimate a lag of up to 0.125 s"):
        estimate_lag(t, x, t, x, max_lag_s=0.125)
    with pytest.raises(ConfigError, match="half a grid step"):
        estimate_lag(T, STEPS, T, STEPS, max_lag_s=0.004)


def test_a_half_without_a_clear_peak_of_its_own_is_not_compared():
    # transients in the first half only; the second half is independent noise (its own
    # correlation is far below the gate, its lag anywhere): the whole-run lag stands
    rng = np.random.default_rng(1)
    ref = np.where(T < 20, STEPS, 1.0 + 1e-5 * rng.standard_normal(T.size))
    sig = np.where(T < 20, np.interp(T - 0.37, T, STEPS),
                   1.0 + 1e-5 * rng.standard_normal(T.size))
    second = T >= 20
    half = estimate_lag(T[second], ref[second], T[second], sig[second])
    assert half.correlation < 0.3 and abs(half.lag_s - 0.37) > 0.1
    est = gated_lag(T, ref, T, sig)
    assert est.applied and est.reason == ""
    assert est.lag_s == pytest.approx(0.37, abs=0.01)


def test_halves_check_refuses_a_disagreement_just_over_the_tolerance():
    # first half delayed 0.30 s, second 0.45 s: 0.15 s apart, over 0.1 s, under 0.2 s
    from terrain.slip import LagGate
    t = np.arange(0, 40, 0.01)
    steps = np.clip(t - 2.0, 0, 1) + 0.5 * np.clip(t - 8.0, 0, 1) * (t < 12) \
        - 0.7 * np.clip(t - 25.0, 0, 1) + 0.4 * np.clip(t - 31.0, 0, 1) * (t < 35)
    half = np.where(t < 20, np.interp(t - 0.3, t, steps), np.interp(t - 0.45, t, steps))
    split = gated_lag(t, steps, t, half, gate=LagGate(halves_tolerance_s=0.1))
    assert not split.applied and "(+0.300 and +0.450 s)" in split.reason
    assert gated_lag(t, steps, t, half, gate=LagGate(halves_tolerance_s=0.2)).applied


def test_the_default_gate_wants_the_halves_within_0_1_s():
    # docs/estimation_validation.md: `--lag xcorr` applies a lag only where the two halves of
    # the run agree within 0.1 s; the default gate refuses halves 0.15 s apart
    # (hand mutant: default halves_tolerance_s 0.3, no test failed)
    t = np.arange(0, 40, 0.01)
    steps = np.clip(t - 2.0, 0, 1) + 0.5 * np.clip(t - 8.0, 0, 1) * (t < 12) \
        - 0.7 * np.clip(t - 25.0, 0, 1) + 0.4 * np.clip(t - 31.0, 0, 1) * (t < 35)
    half = np.where(t < 20, np.interp(t - 0.3, t, steps), np.interp(t - 0.45, t, steps))
    est = gated_lag(t, steps, t, half)
    assert not est.applied and "(+0.300 and +0.450 s)" in est.reason
    same = np.interp(t - 0.3, t, steps)
    assert gated_lag(t, steps, t, same).applied


def test_the_gate_bounds_are_inclusive_as_documented():
    """A peak of exactly ``min_correlation`` is clear ("at least"), and halves exactly
    ``halves_tolerance_s`` apart agree ("differ by more than" is refused); a hair past either
    bound is refused (hand mutants: ``<=`` and ``>=`` in gated_lag survived every test)."""
    from terrain.slip import LagGate
    half = np.where(T < 20, np.interp(T - 0.3, T, STEPS), np.interp(T - 0.45, T, STEPS))
    whole = estimate_lag(T, STEPS, T, half)
    at = gated_lag(T, STEPS, T, half,
                   gate=LagGate(min_correlation=whole.correlation, halves_tolerance_s=None))
    assert at.applied and at.reason == ""
    above = gated_lag(T, STEPS, T, half, gate=LagGate(
        min_correlation=float(np.nextafter(whole.correlation, 1.0)), halves_tolerance_s=None))
    assert not above.applied and "below" in above.reason
    # the halves gated_lag compares: split at the middle of the overlap
    first = T < 0.5 * (T[0] + T[-1])
    lags = [estimate_lag(T[m], STEPS[m], T[m], half[m]).lag_s for m in (first, ~first)]
    apart = abs(lags[0] - lags[1])
    assert apart == pytest.approx(0.15, abs=0.002)
    assert gated_lag(T, STEPS, T, half, gate=LagGate(halves_tolerance_s=apart)).applied
    assert not gated_lag(T, STEPS, T, half, gate=LagGate(
        halves_tolerance_s=float(np.nextafter(apart, 0.0)))).applied
