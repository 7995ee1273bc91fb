"""The switch-transient bound of benchmarks/stream_transient_bound.py on a known stream."""

from __future__ import annotations

import runpy
from pathlib import Path

from terrain.serving.evaluation import Segment

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "stream_transient_bound.py"


def test_window_shares_of_one_switch():
    window_shares = runpy.run_path(str(SCRIPT))["window_shares"]
    # 10 s of A then 10 s of B on one clock; 2 s windows every 0.5 s from t = 2 s
    segments = [Segment("a/A/0", "A", 0.0, 0.0, 10.0), Segment("b/B/0", "B", 5.0, 5.0, 10.0)]
    n, settled, mostly_new, mostly_old = window_shares(segments, 0.5, 2.0)
    assert n == 36                       # t = 2.0 ... 19.5
    assert settled == 16 + 16            # t < 10 in A; t >= 12 in B
    assert mostly_old == 2               # t = 10.0, 10.5: more than half of the window on A
    assert mostly_new == 2               # t = 11.0 (half on each: new), 11.5
    # a second piece of the same terrain is no switch
    same = [Segment("a/A/0", "A", 0.0, 0.0, 10.0), Segment("a/A/1", "A", 0.0, 10.0, 10.0)]
    assert window_shares(same, 0.5, 2.0) == (36, 36, 0, 0)


def test_a_window_is_mostly_old_when_its_middle_is_before_the_switch():
    window_shares = runpy.run_path(str(SCRIPT))["window_shares"]
    # 4 s windows every 0.5 s, switch at 10 s: t = 10.0 ... 11.5 have 4, 3.5, 3, 2.5 s of
    # their window on A (more than half: old); t = 12.0 is half on each (new), t = 12.5,
    # 13.0, 13.5 mostly on B
    segments = [Segment("a/A/0", "A", 0.0, 0.0, 10.0), Segment("b/B/0", "B", 5.0, 5.0, 10.0)]
    n, settled, mostly_new, mostly_old = window_shares(segments, 0.5, 4.0)
    assert n == 32                       # t = 4.0 ... 19.5
    assert settled == 12 + 12            # t < 10 in A; t >= 14 in B
    assert mostly_old == 4
    assert mostly_new == 4
