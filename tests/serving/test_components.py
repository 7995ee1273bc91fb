"""Ring buffer, sample rules, forward filter and catalogue targets."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.serving.buffers import RingBuffer
from terrain.serving.rules import (finite_values, plausible_gyro, plausible_time,
                                   plausible_values, time_increasing)
from terrain.serving.smoothing import (ForwardFilter, SmoothingConfig, forward_step,
                                       predict_steps)
from terrain.serving.targets import CataloguePeakTargets
from terrain.terramechanics import get_terrain, steady_slip


def test_ring_buffer_keeps_newest_samples_in_order_and_never_grows():
    buf = RingBuffer(2, capacity=50)
    shape = buf._t.shape, buf._v.shape  # fixed at construction (a mirrored ring: 2 x 50)
    t = np.arange(1000) * 0.01
    for a in range(0, 1000, 7):  # odd chunk size: wraps at every position
        buf.append(t[a:a + 7], np.column_stack([t[a:a + 7], -t[a:a + 7]]))
    assert len(buf) == 50 and (buf._t.shape, buf._v.shape) == shape == ((100,), (100, 2))
    ts, vs = buf.since(-np.inf)
    np.testing.assert_array_equal(ts, t[-50:])
    np.testing.assert_array_equal(vs[:, 1], -t[-50:])
    ts, _ = buf.since(t[-10])
    assert ts[0] == t[-11] and len(ts) == 11  # plus the sample just before


def test_ring_buffer_chunk_larger_than_capacity_keeps_its_tail():
    buf = RingBuffer(1, capacity=4)
    buf.append(np.arange(10.0), np.arange(10.0)[:, None])
    np.testing.assert_array_equal(buf.since(-np.inf)[0], [6, 7, 8, 9])
    assert buf.first_t == 6 and buf.last_t == 9


def test_ring_buffer_single_samples_equal_chunks_across_the_wrap():
    """The one-sample path of ``append`` (the usual push) stores what a chunk stores."""
    t = np.arange(37) * 0.1
    v = np.column_stack([t, t ** 2, -t])
    one, chunk = RingBuffer(3, capacity=8), RingBuffer(3, capacity=8)
    for k in range(37):
        one.append(t[k:k + 1], v[k:k + 1])
        if k % 5 == 4 or k == 36:
            chunk.append(t[k - k % 5:k + 1], v[k - k % 5:k + 1])
            for a, b in zip(one.since(-np.inf), chunk.since(-np.inf)):
                np.testing.assert_array_equal(a, b)
            assert (len(one), one.first_t, one.last_t) == (len(chunk), chunk.first_t,
                                                           chunk.last_t)
    np.testing.assert_array_equal(one.since(-np.inf)[0], t[-8:])


def test_rules_reject_what_the_readers_reject():
    t = np.array([1.0, 2.0, 2.0, 1.5, 3.0])
    keep, reason = time_increasing(("vel_l",), t, np.zeros((5, 1)), 0.5)
    assert reason == "time_not_increasing"
    np.testing.assert_array_equal(keep, [True, True, False, False, True])
    keep, _ = time_increasing(("vel_l",), np.array([1.0]), np.zeros((1, 1)), 1.0)
    assert not keep[0]  # a duplicate of the last accepted time
    v = np.array([[0.1, 0.2], [np.nan, 0.2], [0.1, np.inf]])
    np.testing.assert_array_equal(finite_values(("a", "b"), np.arange(3.0), v, -np.inf)[0],
                                  [True, False, False])
    gyro = np.array([[0.5, 0.0, 0.0], [0.0, 0.0, 40.0]])  # 40 rad/s: deg/s sent as rad/s
    np.testing.assert_array_equal(plausible_gyro(("wx", "wy", "wz"), np.arange(2.0), gyro,
                                                 -np.inf)[0], [True, False])
    assert plausible_gyro(("vel_l",), np.arange(2.0), 100 * np.ones((2, 1)), -np.inf)[0].all()
    # the readers' ranges (terrain.io.plausibility.CHANNEL_LIMITS): 5 m/s, 1000 A, 24 g;
    # the gyro is left to plausible_gyro
    v = np.array([[4.9, -999.0, 230.0, 40.0], [5.1, 0.0, 0.0, 0.0],
                  [0.0, -1001.0, 0.0, 0.0], [0.0, 0.0, -236.0, 0.0]])
    keep, reason = plausible_values(("vel_l", "cur_r", "az", "wz"), np.arange(4.0), v, -np.inf)
    assert reason == "implausible_value"
    np.testing.assert_array_equal(keep, [True, False, False, False])
    keep, reason = plausible_time(("vel_l",), np.array([1.8e9, -1e10, 1.8e12, 1e300]),
                                  np.zeros((4, 1)), -np.inf)
    assert reason == "implausible_time"
    np.testing.assert_array_equal(keep, [True, True, False, False])


def test_forward_step_is_a_normalised_sticky_markov_prediction():
    p = np.array([0.7, 0.2, 0.1])
    prior = forward_step(p, None, 0.1, 1.0)
    assert prior.sum() == pytest.approx(1.0)
    # stay with 0.9, move uniformly to the 2 others with 0.1
    assert prior[0] == pytest.approx(0.9 * 0.7 + 0.1 * 0.3 / 2)
    post = forward_step(p, np.array([0.1, 0.8, 0.1]), 0.1, 1.0)
    assert post.sum() == pytest.approx(1.0) and post[1] > p[1]


def _switch_step(dwell_s, hysteresis=0.0):
    filt = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=dwell_s, hysteresis=hysteresis))
    for _ in range(40):
        filt.update(np.array([0.8, 0.1, 0.1]))
    for k in range(200):
        if filt.update(np.array([0.2, 0.7, 0.1]))[0] == 1:
            return k + 1
    return np.inf


@pytest.mark.parametrize("seed", range(20))
def test_predict_steps_is_n_prediction_only_forward_steps(seed):
    # the closed form a skipped silent stretch uses must be the recursion written out
    rng = np.random.default_rng(seed)
    k = int(rng.integers(2, 10))
    p = rng.dirichlet(np.ones(k))
    p_switch, n = float(rng.uniform(0, 1)), int(rng.integers(0, 60))
    expected = p
    for _ in range(n):
        expected = forward_step(expected, None, p_switch, 0.5)
    got = predict_steps(p, n, p_switch)
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)
    assert got.sum() == pytest.approx(1.0)
    # a million steps forget the past: the uniform distribution, in one step of work
    if 0 < p_switch < (k - 1) / k:
        np.testing.assert_allclose(predict_steps(p, 10 ** 6, p_switch), 1 / k, atol=1e-12)


def test_filter_skip_moves_p_as_repeated_updates_without_a_window():
    a, b = (ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=5.0)) for _ in range(2))
    for f in (a, b):
        f.update(np.array([0.1, 0.8, 0.1]))
    for _ in range(7):
        decided, p = a.update(None)
    b.skip(7)
    np.testing.assert_allclose(b.p, p, rtol=1e-12)
    assert b.current == decided == 1


def test_longer_dwell_and_hysteresis_delay_the_switch_but_it_happens():
    unsmoothed, short, long_ = _switch_step(None), _switch_step(5.0), _switch_step(60.0)
    assert unsmoothed == 1
    assert 1 < short < long_ < np.inf
    assert _switch_step(5.0, hysteresis=0.5) > short


def test_reset_follows_a_confident_switch_within_its_window_count():
    # after a long stretch of class 0 the filter needs many windows to follow class 1; with
    # the reset it follows on the m-th confident window, and not on less confident ones
    plain = _switch_step(60.0)
    for m in (1, 2, 3):
        filt = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=60.0, reset_confidence=0.7,
                                                     reset_windows=m))
        for _ in range(40):
            filt.update(np.array([0.8, 0.1, 0.1]))
        steps = [filt.update(np.array([0.2, 0.7, 0.1]))[0] for _ in range(m)]
        assert steps[-1] == 1 and all(s == 0 for s in steps[:-1]) and m < plain
        # restarted from the window's probabilities (floored, normalised)
        np.testing.assert_allclose(filt.p, [0.2, 0.7, 0.1])
    filt = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=60.0, reset_confidence=0.75))
    for _ in range(40):
        filt.update(np.array([0.8, 0.1, 0.1]))
    assert [filt.update(np.array([0.2, 0.7, 0.1]))[0] for _ in range(3)] == [0, 0, 0]


def _reference_reset(proba, theta, m):
    """The reset rule written out separately: default filter, then the streak count."""
    filt = ForwardFilter(proba.shape[1], 0.5, SmoothingConfig())
    out, streak, last = [], 0, None
    for q in proba:
        decided = filt.update(q)[0]
        top = int(np.argmax(q))
        if q[top] >= theta and top != decided:
            streak = streak + 1 if top == last else 1
        else:
            streak = 0
        last = top
        if streak >= m:
            filt.p = np.maximum(q, 1e-4) / np.maximum(q, 1e-4).sum()
            filt.current = decided = top
            streak = 0
        out.append(decided)
    return out


@pytest.mark.parametrize("seed", range(5))
def test_reset_equals_the_rule_written_out(seed):
    rng = np.random.default_rng(seed)
    # blocks of one dominant class with noisy, sometimes confidently wrong windows
    labels = np.repeat(rng.integers(0, 4, 12), rng.integers(5, 40, 12))
    logits = rng.normal(0.0, 1.5, (len(labels), 4))
    logits[np.arange(len(labels)), labels] += 2.0
    proba = np.exp(logits) / np.exp(logits).sum(axis=1, keepdims=True)
    plain = _reference_reset(proba, 1.1, 1)                # theta > 1: never resets
    acted = []
    for theta, m in ((0.8, 1), (0.8, 2), (0.6, 3)):
        filt = ForwardFilter(4, 0.5, SmoothingConfig(reset_confidence=theta, reset_windows=m))
        got = [filt.update(q)[0] for q in proba]
        assert got == _reference_reset(proba, theta, m)
        acted.append(got != plain)
    assert acted[0]                                         # the reset acts on these data


def test_no_decision_before_a_valid_window_and_invalid_windows_only_predict():
    filt = ForwardFilter(2, 0.5, SmoothingConfig(dwell_s=10.0))
    assert filt.update(None)[0] is None
    filt.update(np.array([0.9, 0.1]))
    decided, p = filt.update(None)
    assert decided == 0 and 0.5 < p[0] < 0.9 ** 0.5 / (0.9 ** 0.5 + 0.1 ** 0.5) + 1e-12


def test_a_dwell_shorter_than_the_hop_forgets_the_past_rather_than_pushing_away_from_it():
    # hop 0.5 s, dwell 0.2 s: the leave probability was held at 1, so the prediction put all
    # of the last terrain's belief on the other class and a window mildly naming terrain 0
    # after a confident one was decided as 1; a dwell that short means no memory (uniform)
    filt = ForwardFilter(2, 0.5, SmoothingConfig(dwell_s=0.2))
    filt.update(np.array([0.99, 0.01]))
    decided, p = filt.update(np.array([0.6, 0.4]))
    assert decided == 0
    np.testing.assert_allclose(p, forward_step(np.array([0.5, 0.5]), np.array([0.6, 0.4]),
                                               0.5, 0.5))


@pytest.mark.parametrize("kwargs", [dict(dwell_s=0.0), dict(dwell_s=float("inf")),
                                    dict(dwell_s=float("nan")), dict(dwell_s="10"),
                                    dict(evidence_power=0.0),
                                    dict(hysteresis=1.0), dict(reset_confidence=0.0),
                                    dict(reset_confidence=0.9, dwell_s=None),
                                    dict(reset_windows=0)])
def test_smoothing_config_is_checked(kwargs):
    with pytest.raises(ConfigError):
        SmoothingConfig(**kwargs)


def test_catalogue_targets_are_the_curve_peaks_and_the_fallback_the_slipperiest():
    targets = CataloguePeakTargets(["ASPHALT", "ICE", "SNOW"], min_confidence=0.6)
    asphalt = get_terrain("ASPHALT").curve  # Burckhardt: peak at ln(c1 c2 / c3) / c2
    peak = np.log(asphalt.c1 * asphalt.c2 / asphalt.c3) / asphalt.c2
    t = targets.target_for("ASPHALT", 0.9, False)
    assert t.traction == pytest.approx(peak) and t.braking == pytest.approx(-peak)
    assert targets.target_for("SNOW", 0.9, False).steady == pytest.approx(
        steady_slip(get_terrain("SNOW")))
    ice = targets.target_for("ICE", 0.9, False)
    assert ice.traction == min(v.traction for v in targets.table.values())
    for args in [(None, 0.9, False), ("SNOW", 0.5, False), ("SNOW", 0.9, True)]:
        assert targets.target_for(*args) == ice
    with pytest.raises(ConfigError):
        CataloguePeakTargets(["NOT_A_TERRAIN"])


def test_the_service_slip_targets_are_the_controllers_checked_record():
    """terrain.serving had its own SlipTargets (a NamedTuple with no checks) beside the
    controller's record of the same name and meaning, which refuses a wrong sign:
    serving's SlipTargets(-0.1, 0.15, -0.05) was accepted and would have reached the
    controller. There is one class now, checked, and it still unpacks as the service
    reads a provider's targets (``traction, braking, steady = ...``)."""
    import terrain.control
    import terrain.serving
    from terrain.serving.targets import SlipTargets, TableTargets

    assert SlipTargets is terrain.serving.SlipTargets is terrain.control.SlipTargets
    with pytest.raises(ConfigError, match=r"SlipTargets\.traction must be in \(0, 1\]"):
        SlipTargets(-0.1, 0.15, -0.05)
    for provider in (CataloguePeakTargets(["ASPHALT", "ICE", "SNOW"]),
                     TableTargets(["ASPHALT", "ICE", "SNOW"])):
        got = provider.target_for("SNOW", 0.9, False)
        assert isinstance(got, SlipTargets)
        traction, braking, steady = got
        assert (traction, braking, steady) == (got.traction, got.braking, got.steady)


def test_table_targets_follow_the_desired_slip_table_and_its_fallback():
    from terrain.control import build_slip_table, select_target
    from terrain.serving.targets import TableTargets

    classes = ["ASPHALT", "ICE", "SNOW"]
    targets = TableTargets(classes)
    table = build_slip_table(classes)
    snow = select_target(table, "SNOW", 0.9, 0.0)
    assert tuple(targets.target_for("SNOW", 0.9, False)) == (snow.traction, snow.braking,
                                                             snow.steady)
    fb = table.fallback
    for args in [(None, 0.9, False), ("SNOW", 0.1, False), ("SNOW", 0.9, True)]:
        assert tuple(targets.target_for(*args)) == (fb.traction, fb.braking, fb.steady)
    assert targets.fallback.traction == fb.traction


@pytest.mark.parametrize("dwell_s", [10.0, None])
def test_a_window_of_non_finite_probabilities_is_no_evidence_and_never_poisons_the_filter(
        dwell_s):
    # a NaN (or inf) window made p NaN for good: every later decision named class 0 (argmax
    # of NaN) with a NaN confidence, whatever the windows said
    filt = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=dwell_s))
    good = np.array([0.1, 0.7, 0.2])
    filt.update(good)
    ref = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=dwell_s))
    ref.update(good)
    for bad in (np.full(3, np.nan), np.array([np.inf, 1.0, 0.0]), np.array([0.5, np.nan, 0.5])):
        decided, p = filt.update(bad)
        assert np.isfinite(p).all() and p.sum() == pytest.approx(1.0)
        np.testing.assert_allclose(p, ref.update(None)[1])    # a prediction-only step
        assert decided == 1
    decided, p = filt.update(good)
    assert decided == 1 and np.isfinite(p).all() and p.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("dwell_s", [10.0, None])
def test_a_first_window_of_non_finite_probabilities_decides_nothing_with_or_without_filter(
        dwell_s):
    # with the filter on, a NaN first window (no evidence yet) was decided as the prior's
    # argmax (class 0 at 1/K) while the unfiltered filter gave no decision
    filt = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=dwell_s))
    for bad in (np.full(3, np.nan), np.array([np.inf, 1.0, 0.0])):
        decided, p = filt.update(bad)
        assert decided is None and not filt.evidence
        np.testing.assert_allclose(p, np.full(3, 1 / 3))
    assert filt.update(np.array([0.1, 0.7, 0.2]))[0] == 1 and filt.evidence


def test_rules_keep_a_value_at_the_readers_limit_and_refuse_stamps_far_either_side_of_0():
    """The boundaries of the sample rules, as the readers draw them
    (:func:`terrain.io.plausibility.check_ranges` refuses only beyond a limit): a value
    exactly at its limit is kept, the next float past it refused, in either sign; a stamp
    far before 0 (a corrupted or negative epoch stamp) is as implausible as one far after."""
    from terrain.io.plausibility import CHANNEL_LIMITS

    speed, gyro = CHANNEL_LIMITS["vel_l"].limit, CHANNEL_LIMITS["wz"].limit
    above = np.nextafter(speed, np.inf)
    v = np.array([[speed], [-speed], [above], [-above]])
    keep, _ = plausible_values(("vel_l",), np.arange(4.0), v, -np.inf)
    np.testing.assert_array_equal(keep, [True, True, False, False])
    g = np.array([[gyro], [-gyro], [np.nextafter(gyro, np.inf)]])
    keep, _ = plausible_gyro(("wz",), np.arange(3.0), g, -np.inf)
    np.testing.assert_array_equal(keep, [True, True, False])
    t = np.array([-1.8e12, -1e300, -1e11, 1e11])
    keep, _ = plausible_time(("vel_l",), t, np.zeros((4, 1)), -np.inf)
    np.testing.assert_array_equal(keep, [False, False, True, True])


def test_forward_step_floors_a_zero_probability_and_ignores_a_non_finite_window():
    """One window with a class at probability 0 must not put that class at 0 (the floor,
    :data:`~terrain.serving.smoothing.PROBA_FLOOR`: the filter must be able to come back to
    it), and a window holding a NaN or inf is no evidence (prediction only), as its
    docstring says, also when called directly rather than through ``ForwardFilter``."""
    from terrain.serving.smoothing import PROBA_FLOOR

    p = np.array([0.2, 0.5, 0.3])
    prior = forward_step(p, None, 0.1, 0.5)
    post = forward_step(p, np.array([1.0, 0.0, 0.0]), 0.1, 0.5)
    want = prior * np.array([1.0, PROBA_FLOOR, PROBA_FLOOR]) ** 0.5
    np.testing.assert_allclose(post, want / want.sum(), rtol=1e-12)
    assert (post > 0).all()
    for bad in (np.array([np.nan, 0.5, 0.5]), np.array([np.inf, 0.0, 0.0])):
        np.testing.assert_allclose(forward_step(p, bad, 0.1, 0.5), prior, rtol=1e-12)


def test_a_reset_restarts_from_the_floored_window_so_no_class_is_ruled_out():
    filt = ForwardFilter(3, 0.5, SmoothingConfig(dwell_s=60.0, reset_confidence=0.9,
                                                 reset_windows=1))
    for _ in range(40):
        filt.update(np.array([0.8, 0.1, 0.1]))
    assert filt.current == 0
    decided, p = filt.update(np.array([0.05, 0.95, 0.0]))   # class 2 at 0: floored
    assert decided == 1
    from terrain.serving.smoothing import PROBA_FLOOR
    want = np.array([0.05, 0.95, PROBA_FLOOR])
    np.testing.assert_allclose(p, want / want.sum(), rtol=1e-12)


def test_catalogue_targets_trust_a_confidence_at_the_threshold_and_check_its_range():
    targets = CataloguePeakTargets(["ASPHALT", "ICE", "SNOW"], min_confidence=0.6)
    assert targets.target_for("SNOW", 0.6, False) == targets.table["SNOW"] != targets.fallback
    assert targets.target_for("SNOW", np.nextafter(0.6, 0), False) == targets.fallback
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ConfigError, match="min_confidence"):
            CataloguePeakTargets(["ICE"], min_confidence=bad)


def test_ring_buffer_counts_exactly_the_samples_an_append_pushes_out():
    """``evicted`` / ``evicted_times`` (the service's ``buffer_overflow`` count): the
    oldest held samples, then a chunk's own first ones when it is longer than the buffer,
    only those at or after ``since_s``; nothing while the buffer still has room."""
    buf = RingBuffer(1, capacity=4)
    buf.append(np.array([0.0, 1.0, 2.0]), np.zeros((3, 1)))
    one = np.array([3.0])
    assert buf.evicted(one, -np.inf) == 0 and buf.evicted_times(one, -np.inf).size == 0
    buf.append(one, np.zeros((1, 1)))                          # full: 0, 1, 2, 3
    assert buf.evicted(np.array([4.0]), -np.inf) == 1
    assert buf.evicted(np.array([4.0]), 0.0) == 1               # at since_s: still needed
    assert buf.evicted(np.array([4.0]), 0.5) == 0
    chunk = np.arange(4.0, 10.0)                                # 6 samples into 4 slots
    np.testing.assert_array_equal(buf.evicted_times(chunk, -np.inf), [0, 1, 2, 3, 4, 5])
    np.testing.assert_array_equal(buf.evicted_times(chunk, 1.0), [1, 2, 3, 4, 5])
    assert buf.evicted(chunk, 1.0) == 5
    assert buf.evicted(chunk[:2], 1.0) == 1                     # 0 and 1 go; 0 not needed


def test_ring_buffer_lookups_take_a_sample_at_the_asked_time():
    buf = RingBuffer(1, capacity=8)
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.5, 0.6])                # a gap of 0.2 s
    buf.append(t, t[:, None])
    assert buf.first_at_or_after(0.3) == 0.3 and buf.first_at_or_after(0.31) == 0.5
    assert buf.first_at_or_after(0.61) == np.inf
    # the step up to the first sample at or after through_s, whatever came after
    assert buf.median_step(through_s=0.3) == pytest.approx(0.1)
    assert buf.median_step(through_s=0.0) != buf.median_step(through_s=0.0)   # nan: 1
    assert buf.median_step() == pytest.approx(0.1)              # steps .1 .1 .1 .2 .1
    assert buf.median_step(last=3) == pytest.approx(0.15)       # steps .2 .1: newest 3
    assert buf.median_step(last=3, through_s=0.5) == pytest.approx(0.15)
    buf.drop_newest(-3)                                         # never adds samples
    assert len(buf) == 6 and buf.last_t == 0.6
    buf.drop_newest(2)
    assert len(buf) == 4 and buf.last_t == 0.3


def test_ring_buffer_batch_first_t_is_the_first_stamp_of_the_newest_push():
    """What the service judges a lagging stream's staleness from: a chunk's samples
    arrived together, so the stream had reached its first stamp when they came."""
    buf = RingBuffer(1, capacity=8)
    assert buf.batch_first_t == -np.inf
    buf.append(np.array([1.0, 1.1, 1.2]), np.zeros((3, 1)))
    assert buf.batch_first_t == 1.0 and buf.last_t == 1.2
    buf.append(np.array([1.3]), np.zeros((1, 1)))
    assert buf.batch_first_t == 1.3
    buf.append(np.array([1.4, 1.5]), np.zeros((2, 1)))
    buf.drop_newest(2)                                          # never past the newest kept
    assert buf.batch_first_t == buf.last_t == 1.3


def _stuck_data(seed, lengths):
    """8 Hz samples (binary-exact stamps) of 3 channels, the last two with stretches of one
    value planted (``lengths`` samples each), some just at the rule's limits (20 s for a
    current, 1 s for the IMU, and 10 samples), some just short of them."""
    rng = np.random.default_rng(seed)
    n = 2400
    t = np.arange(n) * 0.125
    v = rng.normal(0.0, 1.0, (n, 3))
    for col in (1, 2):
        a = int(rng.integers(0, 40))
        while a < n - 10:
            length = int(rng.choice(lengths))
            v[a:a + length, col] = round(float(rng.normal()), 2)
            a += length + int(rng.integers(1, 60))
    return t, v


@pytest.mark.parametrize("stream, channels, lengths", [
    # currents: 161 samples at 8 Hz are exactly 20 s, 160 are short of it
    ("wheels", ("vel_l", "cur_l", "cur_r"), (160, 161, 170, 3, 120, 200)),
    # a gyro: 9 samples at 8 Hz span its 1 s but are one short of 10, 10 samples are stuck
    ("imu", ("ax", "wx", "wz"), (8, 9, 10, 11, 30)),
])
@pytest.mark.parametrize("seed", range(3))
def test_stuck_watch_finds_the_readers_stretches_whatever_the_chunking(
        seed, stream, channels, lengths):
    """The live stuck-sensor rule (:class:`~terrain.serving.rules.StuckWatch`) sample by
    sample or in chunks of any size finds the stretches the readers' rule finds on the
    whole stream (:func:`terrain.io.plausibility.stuck_stretches`), bounds included, the
    one still going at the end as well."""
    import pandas as pd

    from terrain.io.plausibility import stuck_stretches
    from terrain.run import TIME
    from terrain.serving.rules import StuckWatch

    t, v = _stuck_data(seed, lengths)
    # a last sample of new values ends every stretch, the one going on at the end included
    t, v = np.r_[t, t[-1] + 0.125], np.vstack([v, [[7.0, 7.0, 7.0]]])
    frame = pd.DataFrame({TIME: t, **{c: v[:, j] for j, c in enumerate(channels)}})
    want = stuck_stretches({stream: frame})
    assert sum(len(s) for s in want.values()) >= 4
    rng = np.random.default_rng(100 + seed)
    for sizes in ("one", "random", "whole"):
        watch = StuckWatch(stream, channels, max_stretches=128)
        a = 0
        while a < len(t):
            k = {"one": 1, "whole": len(t)}.get(sizes) or int(rng.integers(1, 300))
            watch.update(t[a:a + k], v[a:a + k])
            a += k
        got = {key: [list(s) for s in ended] for key, ended in zip(watch.keys, watch.ended)}
        assert {k: s for k, s in got.items() if s} == want, sizes


def test_stuck_watch_flags_a_window_holding_any_sample_of_the_stretch():
    """A decision's window is ``[t_lo, t_hi)``: a stuck stretch whose last sample is at
    ``t_lo`` is in it, one whose first sample is at ``t_hi`` is not (ended stretches and
    the one still going alike)."""
    from terrain.serving.rules import StuckWatch

    t = np.arange(0, 801) * 0.125                  # 0 .. 100 s at 8 Hz
    x = np.sin(t)                                  # a live current...
    x[(t >= 10.0) & (t <= 40.0)] = 2.5             # ... stuck from 10 s to 40 s
    x[t >= 60.0] = 3.5                             # ... and from 60 s to the end (100 s)
    watch = StuckWatch("wheels", ("cur_l",))
    for k in range(len(t)):
        watch.update(t[k:k + 1], x[k:k + 1, None])
    assert list(watch.ended[0]) == [(10.0, 40.0)]
    flagged = [("wheels.cur_l" in watch.stuck_between(lo, hi))
               for lo, hi in ((40.0, 45.0), (40.125, 45.0), (5.0, 10.0), (5.0, 10.125),
                              (55.0, 60.0), (55.0, 60.125), (100.0, 101.0),
                              (100.125, 101.0))]
    assert flagged == [True, False, False, True, False, True, True, False]


def test_a_replay_swaps_the_live_stuck_flag_for_the_runs_on_each_decisions_own_window():
    """``with_run_stuck_flags`` (``terrain stream``, the served model): the live
    ``stuck:`` flag is dropped, never joined beside the run's (two stuck tokens in one
    decision), and a decision's window is ``[t_s - window_age_s - window_s,
    t_s - window_age_s]``: a stale decision is judged on the window it rests on."""
    from terrain.serving.decisions import Decision, decisions_frame, with_run_stuck_flags

    def decision(t_s, age, flags):
        return Decision(t_s, "SNOW", 0.9, np.array([0.1, 0.9]), 0.2, -0.15, 0.05, age, flags)

    decisions = [decision(10.0, 0.0, "stale|stuck:imu.wz"),     # window [8, 10]
                 decision(20.0, 9.0, "stale|stuck:imu.wz"),     # window [9, 11]: stale
                 decision(13.0, 0.0, "low_confidence"),         # window [11, 13]
                 decision(30.0, 0.0, "")]                       # window [28, 30]
    frame = decisions_frame(decisions, ["ICE", "SNOW"])
    assert frame.loc[0, ["target_slip_traction", "target_slip_braking",
                         "target_slip_steady", "proba_SNOW"]].tolist() == [0.2, -0.15, 0.05, 0.9]
    stuck = {"imu.wz": [[10.5, 12.0]], "wheels.cur_l": [[9.5, 9.6]]}
    flags, n_stuck = with_run_stuck_flags(frame, stuck, 2.0)
    assert flags == ["stale|stuck:wheels.cur_l", "stale|stuck:imu.wz,wheels.cur_l",
                     "low_confidence|stuck:imu.wz", ""]
    assert n_stuck == 3


def test_the_usual_step_is_the_smallest_while_few_steps_are_known():
    """A stream's first steps 0.615, 1.077, 0.154, 0.154 s (two holes): the median,
    0.385 s, is the holes'; the usual step is the smallest until 8 steps are known, then
    the median of the newest 64 samples, as :meth:`RingBuffer.median_step`."""
    buf = RingBuffer(1, 100)
    t = np.r_[0.0, 0.615, 1.692, 1.846 + 0.154 * np.arange(20)]
    buf.append(t, np.zeros((len(t), 1)))
    assert buf.median_step(through_s=2.0) == pytest.approx(0.3845)
    assert buf.usual_step(through_s=2.0) == pytest.approx(0.154)
    assert np.isnan(buf.usual_step(through_s=0.0))            # one sample: no step
    assert buf.usual_step(through_s=0.615) == pytest.approx(0.615)   # one step: itself
    # 8 steps known through the 9th sample (1.846 + 5 x 0.154 s): the median again
    nine = 1.846 + 5 * 0.154
    assert buf.usual_step(through_s=nine - 0.01) == pytest.approx(0.154)
    assert buf.usual_step(through_s=nine) == buf.median_step(through_s=nine)
    assert buf.usual_step() == buf.median_step() == pytest.approx(0.154)
    holes = RingBuffer(1, 100)
    holes.append(np.r_[0.0, 1.0, 2.0, 2.1, 2.2, 3.2, 4.2, 5.2, 6.2], np.zeros((9, 1)))
    assert holes.usual_step() == pytest.approx(1.0)          # 8 steps: the median, 1 s
    assert holes.usual_step(few=9) == pytest.approx(0.1)
