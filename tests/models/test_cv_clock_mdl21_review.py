"""Metamorphic checks of the run-grouped CV cuts (mdl21): shifting every clock by a constant
(a run logged on the Unix epoch clock, ~1.7e9 s, as the aligner keeps it) must not change
which windows are dropped or which split unit a training window belongs to."""

import numpy as np
from hypothesis import given, settings, strategies as st

from terrain.models.cv import purge_block_overlaps, split_single_run_classes, training_units


def _cut(t0_s, rate_hz, n_total, n, hop):
    """Window bounds as ``features.windows`` cuts them from an aligned grid
    ``t0 + k / rate`` (``t_end_s`` = first sample + n periods)."""
    t = t0_s + np.arange(n_total) / rate_hz
    start = np.arange(0, n_total - n + 1, hop)
    return t[start], t[start] + n / rate_hz


cuts = st.tuples(st.sampled_from([30.0, 50.0, 100.0, 200.0]), st.integers(5, 60),
                 st.integers(1, 3), st.integers(4, 9))


@settings(max_examples=60, deadline=None)
@given(cuts, st.floats(1.0e9, 2.0e9), st.integers(2, 4))
def test_clock_shift_keeps_the_purge_and_training_units(cut, epoch_s, n_blocks):
    rate, n, hop_div, length = cut
    hop = max(1, n // hop_div)
    results = []
    for origin in (0.0, epoch_s):
        t0, t1 = _cut(origin, rate, length * n, n, hop)
        labels = np.array(["a"] * len(t0))
        runs = np.array(["r"] * len(t0))
        groups, _ = split_single_run_classes(labels, runs, t0, n_blocks)
        keep = purge_block_overlaps(groups, runs, t0, t1)
        units = training_units(runs, t0, t1, groups, runs, t0, t1)
        results.append((groups.tolist(), keep.tolist(), units.tolist()))
    assert results[0] == results[1]


def test_abutting_windows_on_an_epoch_clock_are_kept():
    # 30 Hz, 57-sample windows side by side: no window shares a sample with another block
    t0, t1 = _cut(1511821624.7002568, 30.0, 239, 57, 57)
    labels, runs = np.array(["a"] * len(t0)), np.array(["r"] * len(t0))
    groups, _ = split_single_run_classes(labels, runs, t0, 3)
    assert purge_block_overlaps(groups, runs, t0, t1).all()
    assert all(u is not None for u in training_units(runs, t0, t1, groups, runs, t0, t1))


def test_a_window_sharing_one_sample_with_the_next_block_is_dropped_on_an_epoch_clock():
    # 200 Hz, 10-sample windows every 9 samples: each shares one sample (5 ms) with the next
    rate = 200.0
    for origin in (0.0, 1.7e9 + 0.37):
        t0, t1 = _cut(origin, rate, 91, 10, 9)
        labels, runs = np.array(["a"] * len(t0)), np.array(["r"] * len(t0))
        groups, _ = split_single_run_classes(labels, runs, t0, 2)
        keep = purge_block_overlaps(groups, runs, t0, t1)
        last_of_first = np.flatnonzero(groups == groups[0])[-1]
        assert keep.tolist() == [i != last_of_first for i in range(len(t0))]
