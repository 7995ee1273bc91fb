"""Slip-augmented skid-steer filter: a pseudo-measurement side without a usable variance is
left out and counted."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.estimation.runner import SensorSamples
from terrain.estimation.skid_steer_slip import (MEASUREMENT_NAMES, SkidSteerSlipSettings,
                                                run_with_pseudo_slip)


def test_a_pseudo_measurement_side_with_a_zero_std_is_left_out_and_counted():
    """A slip model's side with std 0 (no spread: not a usable variance) is left out of its
    update like a non-finite side, and the window is counted in ``non_finite``; the other
    side is still used. Taken as is, the zero std of the side was replaced by the other
    side's and the row entered the update with that made-up variance."""
    t = np.arange(301) / 100.0
    samples = {"wheels": SensorSamples(t, np.full((t.size, 2), 0.3))}
    tp = np.array([0.5, 1.5, 2.5])
    slip = np.full((3, 2), 0.1)
    std = np.array([[0.05, 0.05], [0.05, 0.0], [0.05, 0.05]])
    res = run_with_pseudo_slip(t, samples, SkidSteerSlipSettings(), tp, slip, std)
    c = res.counts["slip_model"]
    assert (c["samples"], c["non_finite"], c["used"]) == (3, 1, 3)
    rows = [MEASUREMENT_NAMES.index("slip_1"), MEASUREMENT_NAMES.index("slip_2")]
    used = res.accepted[:, rows]
    np.testing.assert_array_equal(used.sum(axis=0), [3, 2])
    k = int(np.flatnonzero(used[:, 0])[1])          # the step of the second window
    assert used[k, 0] and not used[k, 1]


def test_a_pseudo_measurement_outside_the_grid_changes_nothing_but_its_count():
    """A slip-model window after the grid's end (or long before its start) is counted as
    outside and never used; it must not set the variance of the segment it was clipped to.
    It did: a window at 3.5 s with std 5 on a grid ending at 3.0 s gave the used window on
    the last step (2.995 s, std 0.05) an innovation variance of 25.0 instead of 0.0036."""
    t = np.arange(301) / 100.0
    samples = {"wheels": SensorSamples(t, np.full((t.size, 2), 0.3))}
    tp = np.array([0.5, 1.5, 2.995])
    ref = run_with_pseudo_slip(t, samples, SkidSteerSlipSettings(slip_psd_rel=1.0), tp,
                               np.full((3, 2), 0.1), np.full(3, 0.05))
    more = run_with_pseudo_slip(t, samples, SkidSteerSlipSettings(slip_psd_rel=1.0),
                                np.r_[-2.0, tp, 3.5], np.full((5, 2), 0.1),
                                np.r_[5.0, np.full(3, 0.05), 5.0])
    assert (more.counts["slip_model"]["outside"], more.counts["slip_model"]["used"]) == (2, 3)
    for name in ("x", "P_diag", "y", "S_diag", "nis"):
        np.testing.assert_array_equal(getattr(more, name), getattr(ref, name), err_msg=name)


@pytest.mark.parametrize("field, value", [("wheel_std_m_s", "0.05"), ("track_m", True),
                                          ("jerk_psd", "abc"), ("slip_std", None),
                                          ("speed_bound_braking_slip", "-0.3")])
def test_slip_settings_that_are_not_real_numbers_are_refused_naming_the_field(field, value):
    """Text passed float() and was kept as text (a later ``** 2`` raised Python's TypeError),
    True was a 1 m track, 'abc' and None were bare ValueError / TypeError: each is a
    ConfigError naming SkidSteerSlipSettings.<field>; speed_bound_braking_slip may still be
    None (no bound)."""
    with pytest.raises(ConfigError,
                       match=rf"SkidSteerSlipSettings\.{field} must be a real number"):
        SkidSteerSlipSettings(**{field: value})
    assert SkidSteerSlipSettings(speed_bound_braking_slip=None).speed_bound_braking_slip is None


def test_the_speed_range_of_one_rim_pair_widens_both_ends_by_the_noise_margin():
    """``[(min(0, a_l) + min(0, a_r)), (max(0, b_l) + max(0, b_r))] / (2 (1 + s_b))`` with
    ``a = omega r - margin``, ``b = omega r + margin``: standing rims give the symmetric
    ``+-margin / (1 + s_b)``, slow forward rims a backward end of ``(margin - omega r) /
    (1 + s_b)``, and a turn on the spot one rim's range each way."""
    from terrain.estimation.skid_steer_slip import rim_speed_range_m_s

    lo, hi = rim_speed_range_m_s(np.array([[0.0, 0.0], [0.05, 0.05], [0.5, -0.5]]), -0.3, 0.09)
    np.testing.assert_allclose(lo, [-0.09 / 0.7, -0.04 / 0.7, -0.59 / 1.4], rtol=1e-12)
    np.testing.assert_allclose(hi, [0.09 / 0.7, 0.14 / 0.7, 0.59 / 1.4], rtol=1e-12)
