"""State review (ftr24): what an aligned-clock helper returns does not depend on the calls
made before it (no memoised answer passes an argument its checks refuse)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings, strategies as st

from terrain.errors import ConfigError
from terrain.io.align import interpolated_mean_count


@pytest.mark.parametrize("earlier, refused", [
    ((1, 10.0, 6.5), (True, 10.0, 6.5)),          # a boolean count equal to 1
    ((20, 10.0, 6.5), (20.0, 10.0, 6.5)),         # a float count equal to 20
    ((20, 1.0, 0.5), (20, True, 0.5)),            # a boolean rate equal to 1 Hz
    ((20, 10.0, 1.0), (20, 10.0, True)),          # a boolean native rate equal to 1 Hz
    ((20, 10.0, 6.5, 1), (20, 10.0, 6.5, True)),  # a boolean phase count equal to 1
])
def test_interpolated_mean_count_refuses_after_an_equal_call(earlier, refused):
    # the memo's key read True as 1 and 20.0 as 20: refused on a first call, the argument
    # was accepted (with the earlier call's answer) once an equal one had been memoised
    with pytest.raises(ConfigError):
        interpolated_mean_count(*refused)
    interpolated_mean_count(*earlier)
    with pytest.raises(ConfigError):
        interpolated_mean_count(*refused)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 200), rate=st.sampled_from([10.0, 50.0, 100.0]),
       native=st.sampled_from([1.0, 6.5, 15.0, 100.0, 200.0]))
def test_interpolated_mean_count_same_answer_whatever_came_before(n, rate, native):
    first = interpolated_mean_count(n, rate, native)
    interpolated_mean_count(n + 1, rate, native)
    assert interpolated_mean_count(n, rate, native) == first
