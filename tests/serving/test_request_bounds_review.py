"""Review of :func:`terrain.serving.request.parse_request`'s bounds, each at its edge: a
request at a limit is taken, one just beyond it refused (mutants moving a ``<`` to ``<=``
survived the request tests)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError, DataWarning, NonFiniteError, TimestampError
from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.request import parse_request, planned_decisions
from terrain.serving.rules import MAX_PLAUSIBLE_TIME_S

IMU = {"imu": IMU_CHANNELS}


def _imu(t: np.ndarray, seed: int = 0) -> pd.DataFrame:
    """A long-format IMU request at the stamps ``t``, plausible noisy values."""
    rng = np.random.default_rng(seed)
    return pd.DataFrame({"stream": "imu", "t_s": t,
                         **{c: (9.81 if c == "az" else 0.0) + 0.1 * rng.standard_normal(t.size)
                            for c in IMU_CHANNELS}})


def test_a_stream_spanning_exactly_one_window_is_taken_and_one_decision_planned():
    t = np.arange(201) / 100.0          # 0 .. 2.0 s exactly
    run = parse_request(_imu(t), IMU, 2.0, 10_000)
    assert planned_decisions(run, 2.0, 0.5) == 1
    with pytest.raises(DataFormatError, match="too short"):
        parse_request(_imu(t[:-1]), IMU, 2.0, 10_000)
    assert planned_decisions(parse_request(_imu(t), IMU, 1.5, 10_000), 1.5, 0.5) == 2


def test_a_request_of_exactly_max_rows_is_taken():
    frame = _imu(np.arange(300) / 100.0)
    assert len(parse_request(frame, IMU, 2.0, 300).streams["imu"]) == 300
    with pytest.raises(DataFormatError, match="exceeds the limit of 299"):
        parse_request(frame, IMU, 2.0, 299)


def test_a_stream_at_its_lowest_nominal_rate_is_taken():
    # the IMU's nominal rates start at 10 Hz (NOMINAL_RATE_HZ)
    run = parse_request(_imu(np.arange(41) / 10.0), IMU, 2.0, 10_000)
    assert len(run.streams["imu"]) == 41
    with pytest.raises(DataFormatError, match="outside its nominal"), \
            pytest.warns(DataWarning, match="timestamp_units"):
        parse_request(_imu(np.arange(41) / 9.0), IMU, 2.0, 10_000)


def test_a_duplicated_timestamp_is_refused_naming_its_row():
    t = np.arange(300) / 100.0
    t[150] = t[149]
    with pytest.raises(TimestampError, match="duplicated timestamp") as err:
        parse_request(_imu(t), IMU, 2.0, 10_000)
    assert err.value.row == 150


def test_a_stamp_at_the_time_bound_is_taken_one_beyond_refused():
    # at 1e11 s a float64 resolves 1.5e-5 s: a 100 Hz stream ending on the bound itself
    t = MAX_PLAUSIBLE_TIME_S - 3.0 + np.arange(301) / 100.0
    assert t[-1] == MAX_PLAUSIBLE_TIME_S
    assert len(parse_request(_imu(t), IMU, 2.0, 10_000).streams["imu"]) == 301
    t[-1] = np.nextafter(MAX_PLAUSIBLE_TIME_S, np.inf)
    with pytest.raises(TimestampError, match="beyond") as err:
        parse_request(_imu(t), IMU, 2.0, 10_000)
    assert err.value.row == 300


def test_the_wheel_channels_are_not_needed_by_an_imu_model():
    frame = pd.concat([_imu(np.arange(300) / 100.0),
                       pd.DataFrame({"stream": "wheels", "t_s": np.arange(60) / 20.0,
                                     **{c: 0.5 for c in WHEEL_CHANNELS}})])
    run = parse_request(frame.reset_index(drop=True), IMU, 2.0, 10_000)
    assert list(run.streams) == ["imu"] and run.meta["unused"] == {"wheels": 60}


def test_a_known_stream_absent_from_the_request_is_not_counted_unused():
    # an IMU model sent IMU rows only: no wheel row is unused (the answer flags none)
    run = parse_request(_imu(np.arange(300) / 100.0), IMU, 2.0, 10_000)
    assert run.meta["unused"] == {} and run.meta["ignored_columns"] == []


def test_a_wide_row_after_a_streams_last_stamp_holding_its_values_is_refused():
    # only a shorter stream's trailing cells may be empty: values without a stamp after
    # the stream's last stamped row are not trailing cells (they would be dropped)
    imu = _imu(np.arange(300) / 100.0).drop(columns="stream").rename(columns={"t_s": "imu_t_s"})
    wheels = pd.DataFrame({"wheels_t_s": np.arange(60) / 20.0,
                           **{c: 0.5 for c in WHEEL_CHANNELS}})
    wide = pd.concat([imu, wheels], axis=1)
    both = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    assert len(parse_request(wide, both, 2.0, 10_000).streams["wheels"]) == 60
    wide.loc[60, "vel_l"] = 0.5
    with pytest.raises(NonFiniteError, match="holds values of the stream's channels") as err:
        parse_request(wide, both, 2.0, 10_000)
    assert err.value.row == 60 and err.value.column == "wheels_t_s"
