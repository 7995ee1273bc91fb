"""Review tests of the held-out stream construction's settings: a piece length or a gap
between pieces that would make a wrong stream is refused, naming the setting."""

from __future__ import annotations

import numpy as np
import pytest
from test_stream_construction import _run

from terrain.errors import ConfigError
from terrain.serving.evaluation import concatenated_streams


def _runs():
    return [_run(0, "ICE"), _run(1, "SNOW"), _run(2, "ICE")]


@pytest.mark.parametrize("settings, field", [
    # a negative gap laid each piece over the end of the one before: the stream's clock
    # went back at every switch (-5 s: two non-increasing steps) and two terrains shared
    # 5 s of stream time
    ({"gap_s": -5.0}, "gap_s"),
    # a NaN or infinite gap put every piece after the first at a NaN or infinite time
    ({"gap_s": float("nan")}, "gap_s"),
    ({"gap_s": float("inf")}, "gap_s"),
    # min_s above max_s was NumPy's bare 'high - low < 0'
    ({"min_s": 50.0, "max_s": 20.0}, "max_s"),
    # a negative min_s made a piece of -0.14 s (seed 0)
    ({"min_s": -1.0}, "min_s"),
    ({"min_s": 0.0}, "min_s"),
    ({"min_s": float("nan")}, "min_s"),
    ({"max_s": float("inf")}, "max_s"),
    ({"gap_s": True}, "gap_s"),
    ({"min_s": "30"}, "min_s")])
def test_piece_lengths_and_gaps_that_make_a_wrong_stream_are_refused(settings, field):
    with pytest.raises(ConfigError, match=f"concatenated_streams.{field}"):
        concatenated_streams(_runs(), ("wheels",), 0, **settings)


def test_valid_piece_settings_give_a_stream_whose_clock_only_goes_forward():
    for settings in ({}, {"gap_s": 0.0}, {"gap_s": 0.1}, {"min_s": 20.0, "max_s": 20.0}):
        stream, segments = concatenated_streams(_runs(), ("wheels",), 0, **settings)
        t = stream.streams["wheels"]["t_s"].to_numpy()
        assert len(segments) == 3 and (np.diff(t) > 0).all()
        assert all(s.duration_s > 0 for s in segments)


@pytest.mark.parametrize("seed", [None, True, 2.5, "0", -1])
def test_a_stream_seed_that_is_not_a_whole_number_is_refused(seed):
    # seed=None strung an unseeded stream, different at every call (the function promises a
    # seeded one: held_out_folds relies on it), True was seed 1, 2.5 NumPy's bare TypeError
    with pytest.raises(ConfigError, match="concatenated_streams.seed"):
        concatenated_streams(_runs(), ("wheels",), seed)


def test_a_numpy_integer_seed_is_the_same_stream_as_the_python_integer():
    assert concatenated_streams(_runs(), ("wheels",), np.int64(3))[1] == \
        concatenated_streams(_runs(), ("wheels",), 3)[1]
