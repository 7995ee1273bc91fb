"""Review of the service's per-sample rules (:mod:`terrain.serving.rules`) against the
readers' (:mod:`terrain.io.plausibility`, :mod:`terrain.io.measured`)."""

from __future__ import annotations

import numpy as np

from terrain.io.plausibility import CHANNEL_LIMITS
from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.rules import (DEFAULT_RULES, finite_values, plausible_gyro,
                                   plausible_time, plausible_values, time_increasing)


def test_a_non_finite_timestamp_is_refused_as_non_finite_whatever_the_values():
    # the reason is the readers' (a non-finite timestamp), not time_not_increasing
    t = np.array([np.nan, 1.0, np.inf, 2.0])
    keep, reason = finite_values(WHEEL_CHANNELS, t, np.zeros((4, len(WHEEL_CHANNELS))), -np.inf)
    assert reason == "non_finite" and keep.tolist() == [False, True, False, True]


def test_the_time_bound_keeps_1e11_s_and_refuses_a_clock_in_ms_since_1976():
    # a Unix time in s (1.8e9) and the bound itself are kept; 2e11 (a ms clock of 1976, or
    # 6,300 years in s) is refused
    keep, reason = plausible_time(IMU_CHANNELS, np.array([1.8e9, 1e11, -1e11, 2e11, -2e11]),
                                  np.zeros((5, 6)), -np.inf)
    assert reason == "implausible_time" and keep.tolist() == [True, True, True, False, False]


def test_an_infinite_value_is_refused_first_as_non_finite_not_as_implausible():
    # the readers repair an isolated inf as a non-finite sample; the service's first rule
    # refuses it under that reason, before the range rules (which would call it implausible)
    values = np.zeros((1, 6))
    values[0, IMU_CHANNELS.index("wz")] = np.inf
    first = [rule(IMU_CHANNELS, np.array([1.0]), values, -np.inf) for rule in DEFAULT_RULES]
    assert next(reason for keep, reason in first if not keep[0]) == "non_finite"


def test_range_rules_judge_each_channel_by_the_readers_bound_on_both_sides():
    for rule, channels in ((plausible_gyro, IMU_CHANNELS), (plausible_values, IMU_CHANNELS),
                           (plausible_values, WHEEL_CHANNELS)):
        for j, c in enumerate(channels):
            if c not in CHANNEL_LIMITS or (rule is plausible_gyro) != (c in ("wx", "wy", "wz")):
                continue
            lim = CHANNEL_LIMITS[c].limit
            values = np.zeros((4, len(channels)))
            values[:, j] = [lim, -lim, np.nextafter(lim, np.inf), -np.nextafter(lim, np.inf)]
            keep, _ = rule(channels, np.arange(4.0), values, -np.inf)
            assert keep.tolist() == [True, True, False, False], c


def test_a_nan_stamp_does_not_make_time_increasing_refuse_the_samples_after_it():
    # the rules are pluggable and each judges the whole chunk: before, the running maximum
    # became NaN at the NaN stamp and every later sample of the chunk was refused as
    # time_not_increasing (keep [True, False, False, False, False])
    keep, reason = time_increasing(IMU_CHANNELS, np.array([1.0, np.nan, 2.0, 1.5, 3.0]),
                                   np.zeros((5, 6)), -np.inf)
    assert reason == "time_not_increasing"
    assert keep.tolist() == [True, False, True, False, True]
    keep, _ = time_increasing(IMU_CHANNELS, np.array([np.nan, 0.5, 2.0]), np.zeros((3, 6)),
                              1.0)
    assert keep.tolist() == [False, False, True]
