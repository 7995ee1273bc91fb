"""Review tests of the held-out stream scores (:mod:`terrain.serving.evaluation`) on a
hand-made stream: what counts as a terrain switch, when its delay starts and ends, the
true terrain at a piece's bounds, settled accuracy and the decisions before the first."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.serving.evaluation import Segment, score_stream, switching_delays, truth_at

# A [0, 10) and another run of A [10, 20) (one terrain: no switch), then B [20, 30),
# C [30, 40), A [40, 50); each piece placed by t_from_s + t_offset_s
SEGMENTS = [Segment("a1", "A", 0.0, 0.0, 10.0), Segment("a2", "A", 3.0, 7.0, 10.0),
            Segment("b", "B", 12.0, 8.0, 10.0), Segment("c", "C", 1.0, 29.0, 10.0),
            Segment("a3", "A", 50.0, -10.0, 10.0)]
T = np.arange(0.0, 50.0, 1.0)
# no decision at 0 and 1; B decided from the very switch to it (t = 20); C never (B all
# through its piece, C only once A has come back, at 45); A back at 43
DECIDED = np.array([None] * 2 + ["A"] * 18 + ["B"] * 23 + ["A"] * 2 + ["C"] + ["A"] * 4,
                   dtype=object)


def test_switching_delays_count_terrain_changes_from_the_switch_inside_the_new_piece():
    delays = switching_delays(SEGMENTS, T, DECIDED)
    # A -> A is no switch; A -> B followed at the switch itself (0 s, not one hop later);
    # B -> C never followed inside C's piece (a C decided later, in A's piece, is no
    # following: inf); C -> A first followed at 43 (its first A, not its last)
    assert delays.tolist() == [0.0, np.inf, 3.0]


def test_truth_at_takes_a_piece_from_its_start_up_to_not_including_its_end():
    segs = [Segment("a", "A", 5.0, -5.0, 10.0), Segment("b", "B", 0.0, 10.5, 10.0)]
    t = np.array([-0.1, 0.0, 9.999, 10.0, 10.25, 10.5, 20.499, 20.5])
    assert truth_at(segs, t).tolist() == [None, "A", "A", None, None, "B", "B", None]


def test_stream_score_counts_undecided_wrong_and_settles_after_one_window():
    score = score_stream(SEGMENTS, T, DECIDED, window_s=2.5)
    # 50 decisions, right: 2..19 (18), 20..29 (10), none in C's piece, 6 of A's at 40..49
    assert score.n_decisions == 50 and score.accuracy == pytest.approx(34 / 50)
    # settled: the terrain 2.5 s earlier is the same (the two A runs are one terrain):
    # 3..19, 23..29, 33..39, 43..49; right: 17 + 7 + 0 + 6
    assert score.n_settled == 38 and score.accuracy_settled == pytest.approx(30 / 38)
    assert score.confusion == {"A": {"none": 2, "A": 24, "B": 3, "C": 1}, "B": {"B": 10},
                               "C": {"B": 10}}
    assert score.delays_s == (0.0, np.inf, 3.0) and score.median_delay_s == 3.0


def test_a_switch_into_two_pieces_of_one_terrain_is_followed_in_either():
    # A [0, 10) -> B [10, 20) and another run of B [20, 30): B first decided at 24, in the
    # second B piece; the terrain has not changed since the switch at 10, so the delay is
    # 14 s (it was inf: only the first B piece was searched). A decision of B in the gap
    # of a later piece of another terrain is still no following.
    segs = [Segment("a", "A", 0.0, 0.0, 10.0), Segment("b1", "B", 0.0, 10.0, 10.0),
            Segment("b2", "B", 5.0, 15.0, 10.0), Segment("c", "C", 0.0, 30.0, 10.0)]
    t = np.arange(0.0, 40.0, 1.0)
    decided = np.array(["A"] * 24 + ["B"] * 6 + ["B"] * 3 + ["C"] * 7, dtype=object)
    assert switching_delays(segs, t, decided).tolist() == [14.0, 3.0]
    late = np.array(["A"] * 30 + ["B"] * 10, dtype=object)   # B only once C has come
    assert switching_delays(segs, t, late).tolist() == [np.inf, np.inf]
