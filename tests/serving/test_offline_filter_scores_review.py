"""Review tests of the held-out stream evaluation: the offline forward filter
(:func:`filter_sequence`) takes exactly as many prediction-only steps as hops a service
skipped, as the live filter takes them one ``update(None)`` at a time; decisions between
pieces are not scored; the stream order's alternation test."""

from __future__ import annotations

import numpy as np

from terrain.serving.evaluation import filter_sequence
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig

#: two classes, leave probability 0.25 per 0.5 s hop: each prediction step halves the
#: belief's distance from uniform (lambda = 1 - 0.25 * 2 / 1 = 0.5)
CONFIG = SmoothingConfig(dwell_s=2.0, evidence_power=1.0)
PROBA = np.array([[0.99, 0.01], [0.4, 0.6]])


def test_a_window_three_hops_after_the_last_takes_two_missed_steps_then_its_own():
    # p after the first window [0.99, 0.01]; three prediction steps (two missed hops and the
    # window's own) leave [0.56125, 0.43875], and 0.4 x 0.56 < 0.6 x 0.44 names class 1;
    # one step fewer ([0.6225, 0.3775]) would keep class 0
    got = filter_sequence(PROBA, 0.5, CONFIG, np.array([0.0, 1.5]))
    filt = ForwardFilter(2, 0.5, CONFIG)
    want = [filt.update(PROBA[0])[0]]
    for _ in range(2):
        filt.update(None)
    want.append(filt.update(PROBA[1])[0])
    assert list(got) == want == [0, 1]
    np.testing.assert_allclose(filt.p, [0.2245, 0.26325] / np.float64(0.48775), rtol=1e-12)
    # one hop apart (or without times): one prediction step, class 0 kept
    assert list(filter_sequence(PROBA, 0.5, CONFIG, np.array([0.0, 0.5]))) == [0, 0]
    assert list(filter_sequence(PROBA, 0.5, CONFIG)) == [0, 0]


def test_missed_hops_are_counted_to_the_nearest_hop_not_down():
    # decision times as written decimals: 2.3 - 0.8 = 1.4999999999999998 s is three hops,
    # 2.9999999999999996 of them in floats; rounding down would take one missed step, not
    # two, and keep class 0 (the two times of the test above, moved by 0.8 s)
    t = np.array([0.8, 2.3])
    assert (t[1] - t[0]) / 0.5 < 3.0
    assert list(filter_sequence(PROBA, 0.5, CONFIG, t)) == \
        list(filter_sequence(PROBA, 0.5, CONFIG, np.array([0.0, 1.5]))) == [0, 1]


def test_decisions_between_pieces_are_not_scored():
    # a 1 s dropout between the pieces (gap_s): the decisions at 10.0 and 10.5 s lie on no
    # terrain; scored against None they would pull the accuracy to 40/42
    from terrain.serving.evaluation import Segment, score_stream

    segments = [Segment("a", "ICE", 0.0, 0.0, 10.0), Segment("b", "SNOW", 5.0, 6.0, 10.0)]
    t = np.arange(1, 42) * 0.5
    decided = np.where(t < 11.0, "ICE", "SNOW").astype(object)
    score = score_stream(segments, t, decided, window_s=2.0)
    assert score.n_decisions == 39 and score.accuracy == 1.0
    assert score.delays_s == (0.0,)
    # settled: the window's start on the same piece (ICE 2.0-9.5 s, SNOW 13.0-20.5 s)
    assert score.n_settled == 16 + 16 and score.accuracy_settled == 1.0


def test_the_terrain_just_placed_cannot_take_the_next_place_so_it_counts_one_less():
    # after a SNOW piece, SNOW SNOW ICE cannot alternate (ICE SNOW SNOW is the only start
    # not repeating SNOW, and it joins the last two), while SNOW ICE ICE can (ICE SNOW ICE):
    # the previous terrain may hold at most half the runs left rounded down, the others
    # half rounded up (SNOW SNOW ICE after an ICE piece: SNOW ICE SNOW)
    from test_stream_construction import _run

    from terrain.serving.evaluation import _can_alternate

    pool = [_run(0, "SNOW"), _run(1, "SNOW"), _run(2, "ICE"), _run(3, "ICE")]
    assert not _can_alternate(pool, [0, 1, 2], "SNOW")
    assert _can_alternate(pool, [0, 1, 2], "ICE")
    assert _can_alternate(pool, [0, 2, 3], "SNOW")
    assert not _can_alternate(pool, [0, 2, 3], "ICE")
