"""Review tests of the forward filter: the per-hop switching probability and the decided
class across a skipped silent stretch; the desired-slip table's fallback entry."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.serving.smoothing import ForwardFilter, SmoothingConfig


@pytest.mark.parametrize("hop_s, dwell_s", [(0.5, 10.0), (0.25, 2.0), (1.0, 4.0)])
def test_one_hop_without_a_window_switches_with_probability_hop_over_dwell(hop_s, dwell_s):
    # a mean dwell of dwell_s seconds on a terrain: leave it with hop_s / dwell_s per hop,
    # to the K - 1 other classes uniformly
    filt = ForwardFilter(3, hop_s, SmoothingConfig(dwell_s=dwell_s))
    filt.p = np.array([1.0, 0.0, 0.0])
    decided, p = filt.update(None)
    ps = hop_s / dwell_s
    np.testing.assert_allclose(p, [1.0 - ps, ps / 2, ps / 2], rtol=1e-12)
    assert filt.p_switch == pytest.approx(ps, rel=1e-12)


def test_a_skipped_stretch_that_forgets_everything_keeps_the_decided_class():
    # a dwell under K/(K-1) hops: one hop forgets all, p is exactly uniform after a skip;
    # a tie is no reason to switch (as update(None) repeated keeps the decided class)
    a, b = (ForwardFilter(2, 0.5, SmoothingConfig(dwell_s=0.2)) for _ in range(2))
    for f in (a, b):
        assert f.update(np.array([0.2, 0.8]))[0] == 1
    for _ in range(3):
        decided, p = a.update(None)
    b.skip(3)
    np.testing.assert_array_equal(b.p, [0.5, 0.5])
    np.testing.assert_allclose(b.p, p, rtol=1e-12)
    assert b.current == decided == 1


def test_table_targets_fallback_is_the_tables_conservative_entry_whole():
    from terrain.control import build_slip_table
    from terrain.serving.targets import TableTargets

    classes = ["ASPHALT", "ICE", "SNOW"]
    fb = build_slip_table(classes).fallback
    assert tuple(TableTargets(classes).fallback) == (fb.traction, fb.braking, fb.steady)
    # the braking target is its own entry, not the traction one mirrored
    assert fb.braking != -fb.traction


def test_without_the_filter_an_invalid_window_reports_no_memory_but_keeps_the_decision():
    # no smoothing: a window not classified gives the uniform distribution, not the last
    # window's probabilities reported as the current ones
    filt = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=None))
    assert filt.update(np.array([0.1, 0.7, 0.2]))[0] == 1
    decided, p = filt.update(None)
    np.testing.assert_array_equal(p, np.full(3, 1 / 3))
    assert decided == 1 and not filt.evidence


def test_catalogue_targets_fall_back_on_a_nan_confidence():
    # 'nan < min_confidence' is False: a NaN confidence got the terrain's own targets
    from terrain.serving.targets import CataloguePeakTargets

    targets = CataloguePeakTargets(("ASPHALT", "ICE", "SNOW"))
    own = max(targets.table, key=lambda c: targets.table[c].traction)   # not the fallback
    assert targets.target_for(own, 0.9, False) == targets.table[own] != targets.fallback
    assert targets.target_for(own, float("nan"), False) == targets.fallback


def test_catalogue_targets_fall_back_on_a_terrain_the_model_does_not_know():
    # a terrain outside the provider's classes (another model's, a typo) is no trust:
    # the fallback, not a KeyError in the control loop
    from terrain.serving.targets import CataloguePeakTargets

    targets = CataloguePeakTargets(("ASPHALT", "ICE"))
    assert "SNOW" not in targets.table
    assert targets.target_for("SNOW", 0.99, False) == targets.fallback


@pytest.mark.parametrize("kwargs", [dict(evidence_power=1.5), dict(evidence_power=-0.5),
                                    dict(reset_confidence=1.2), dict(hysteresis=-0.1)])
def test_smoothing_settings_beyond_their_range_ends_are_refused(kwargs):
    # an evidence power above 1 would weigh one of the overlapping windows as more than one
    # observation; a confidence above 1 is never reached (a reset that never fires)
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError):
        SmoothingConfig(**kwargs)


def test_smoothing_settings_at_their_closed_range_ends_are_taken():
    # evidence power 1 (untempered), a reset at probability 1, no hysteresis; a dwell so
    # long that one certain window alone does not move the filter off class 1 (p0 0.0625)
    config = SmoothingConfig(dwell_s=1e5, evidence_power=1.0, reset_confidence=1.0,
                             reset_windows=1, hysteresis=0.0)
    for reset in (False, True):
        filt = ForwardFilter(2, 0.5, config if reset else replace(config, reset_confidence=None))
        for _ in range(20):
            assert filt.update(np.array([0.2, 0.8]))[0] == 1
        decided, p = filt.update(np.array([1.0, 0.0]))
        if reset:   # restarted from the floored window
            assert decided == 0
            np.testing.assert_allclose(p, np.array([1.0, 1e-4]) / 1.0001, rtol=1e-12)
        else:
            assert decided == 1 and 0.05 < p[0] < 0.07


def test_catalogue_targets_trust_a_confidence_by_the_tables_rule():
    """A percentage (45 for 45 %) or an infinite confidence passed 'confidence >= 0.5' and got
    the terrain's own targets; the desired-slip table's select_target falls back on both.
    Both providers now apply one rule (confidence_is_trusted)."""
    from terrain.control import build_slip_table, select_target
    from terrain.serving.targets import CataloguePeakTargets

    classes = ("ASPHALT", "ICE", "SNOW")
    targets = CataloguePeakTargets(classes)
    table = build_slip_table(list(classes))
    own = max(targets.table, key=lambda c: targets.table[c].traction)
    for confidence, trusted in ((45.0, False), (float("inf"), False), (1.0 + 1e-12, True),
                                (0.5, True), (0.4999, False)):
        assert (targets.target_for(own, confidence, False) != targets.fallback) == trusted
        assert (select_target(table, own, confidence) is not table.fallback) == trusted
