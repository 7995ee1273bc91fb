"""Review of the forward filter, ring buffer and catalogue targets at their bounds (hand
mutants of smoothing.py, buffers.py and targets.py that the other tests let live)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.serving.buffers import RingBuffer
from terrain.serving.config import StreamConfig
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig
from terrain.serving.targets import CataloguePeakTargets


def test_without_the_filter_a_skipped_stretch_reports_no_memory_as_windows_not_classified():
    # skip(n) is documented as n update(None) calls: without the filter each gives the
    # uniform distribution (no memory), so a skip must too; the decided class stays
    a, b = (ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=None)) for _ in range(2))
    for f in (a, b):
        assert f.update(np.array([0.1, 0.7, 0.2]))[0] == 1
    for _ in range(3):
        decided, p = a.update(None)
    b.skip(3)
    np.testing.assert_array_equal(b.p, p)
    np.testing.assert_array_equal(b.p, np.full(3, 1 / 3))
    assert b.current == decided == 1
    b.skip(0)   # no hop skipped: nothing moves
    assert b.current == 1


def test_a_skipped_stretch_keeps_a_decision_the_hysteresis_holds():
    # the prediction only draws p towards uniform, so a class held by the hysteresis margin
    # (another class ahead of it by less than the margin) stays decided over a skip, as over
    # the update(None) calls it stands for
    a, b = (ForwardFilter(2, 0.5, SmoothingConfig(dwell_s=5.0, hysteresis=0.3))
            for _ in range(2))
    for f in (a, b):
        assert f.update(np.array([0.9, 0.1]))[0] == 0
        for _ in range(6):
            f.update(np.array([0.4, 0.6]))
        assert f.current == 0 and f.p[1] > f.p[0]   # held by the margin
    for _ in range(4):
        decided, p = a.update(None)
    b.skip(4)
    np.testing.assert_allclose(b.p, p, rtol=1e-12)
    assert b.current == decided == 0


@pytest.mark.parametrize("n_classes, hop_s", [(3, 0.0), (3, -0.5), (3, float("nan")),
                                              (3, float("inf")), (3, True), (3, "0.5"),
                                              (0, 0.5), (2.0, 0.5), (True, 0.5)])
def test_the_filter_refuses_a_hop_or_class_count_that_is_no_clock(n_classes, hop_s):
    # a hop of 0 made p_switch 0 (a filter that never leaves its first class, the
    # infinite dwell SmoothingConfig refuses), a negative one negative probabilities, a NaN
    # one no memory at all; 0 classes a ZeroDivisionError
    with pytest.raises(ConfigError):
        ForwardFilter(n_classes, hop_s, SmoothingConfig())


def test_a_negative_hop_never_gives_negative_probabilities_because_it_is_refused():
    with pytest.raises(ConfigError, match="hop_s"):
        ForwardFilter(3, -0.5, SmoothingConfig(dwell_s=10.0))
    f = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=10.0))   # the same, a valid hop
    for q in ([0.98, 0.01, 0.01], [0.98, 0.01, 0.01], None, [0.01, 0.01, 0.98]):
        p = f.update(None if q is None else np.array(q))[1]
        assert (p >= 0).all() and p.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("n_channels, capacity", [(3, 0), (0, 4), (-1, 4), (3, -2)])
def test_ring_buffer_refuses_an_empty_shape(n_channels, capacity):
    with pytest.raises(ConfigError):
        RingBuffer(n_channels, capacity)


def test_ring_buffer_median_step_of_two_samples_is_their_step():
    buf = RingBuffer(1, 4)
    buf.append(np.array([1.0]), np.zeros((1, 1)))
    assert np.isnan(buf.median_step())
    buf.append(np.array([1.25]), np.zeros((1, 1)))
    assert buf.median_step() == 0.25
    assert buf.median_step(through_s=1.0) != buf.median_step(through_s=1.0)   # one: NaN
    assert buf.median_step(through_s=1.1) == 0.25


def test_catalogue_targets_take_a_zero_confidence_threshold_and_refuse_no_class():
    targets = CataloguePeakTargets(["ASPHALT", "ICE"], min_confidence=0.0)
    assert targets.target_for("ASPHALT", 0.0, False) == targets.table["ASPHALT"]
    assert targets.target_for("ASPHALT", 0.0, False) != targets.fallback
    with pytest.raises(ConfigError, match="at least one class"):
        CataloguePeakTargets([])


def test_stream_config_refuses_an_infinite_hop_where_it_is_given():
    # StreamConfig(hop_s=inf) was accepted and refused only when a service was built on it
    # (check_hop, naming no StreamConfig); it takes finite hops, as its other durations
    with pytest.raises(ConfigError, match="hop_s must be a finite number of seconds > 0"):
        StreamConfig(hop_s=float("inf"))
    assert StreamConfig(hop_s=2.0).hop_s == 2.0
