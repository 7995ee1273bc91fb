"""Review srv7a of :mod:`terrain.serving.request`: mutants of :func:`parse_request` that no
test killed (the burst rule reading the first run of non-finite values instead of the
longest, the accelerometer-units rule skipped for a model of the accelerometer alone, the
nominal-rate rule skipped for a stream of two samples)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError, DataWarning, NonFiniteError, UnitError
from terrain.run import IMU_CHANNELS
from terrain.serving.request import parse_request

IMU = {"imu": IMU_CHANNELS}


def _imu(t: np.ndarray, seed: int = 0) -> pd.DataFrame:
    """A long-format IMU request at the stamps ``t``, plausible noisy values (m/s^2, rad/s)."""
    rng = np.random.default_rng(seed)
    return pd.DataFrame({"stream": "imu", "t_s": t,
                         **{c: (9.81 if c == "az" else 0.0) + 0.1 * rng.standard_normal(t.size)
                            for c in IMU_CHANNELS}})


def test_a_burst_after_an_isolated_non_finite_value_is_refused_naming_the_burst():
    """An isolated NaN (row 20, repaired) before a burst of 3 (rows 100-102) in one channel:
    the longest run is judged, not the first (mutant ``longest = 0`` took the request)."""
    frame = _imu(np.arange(400) / 100.0)
    frame.loc[20, "wx"] = np.nan
    frame.loc[100:102, "wx"] = np.nan
    with pytest.raises(NonFiniteError, match="burst of 3 non-finite values") as err:
        parse_request(frame, IMU, 2.0, 10_000)
    assert err.value.row == 100 and err.value.column == "wx"
    frame.loc[102, "wx"] = 0.0   # a burst of 2 after the isolated one: both repaired
    assert len(parse_request(frame, IMU, 2.0, 10_000).streams["imu"]) == 400


def test_an_accelerometer_only_model_refuses_a_request_in_g():
    """A model of the accelerometer alone (channels exactly ax, ay, az) still applies the
    readers' accel_units rule: a request in g (az ~ 1) is refused, as a file in g is."""
    accel = {"imu": ("ax", "ay", "az")}
    frame = _imu(np.arange(400) / 100.0)
    assert set(parse_request(frame, accel, 2.0, 10_000).streams["imu"].columns) == {
        "t_s", "ax", "ay", "az"}
    in_g = frame.assign(**{c: frame[c] / 9.81 for c in ("ax", "ay", "az")})
    with pytest.raises(UnitError, match="accel_units"):
        parse_request(in_g, accel, 2.0, 10_000)


def test_a_stream_of_two_samples_below_its_nominal_rate_is_refused():
    """Two wheel samples 2 s apart span a 2 s window but imply 0.5 Hz, below the wheels'
    nominal rates: refused as any stream off its rate (the rule needs 2 samples, not 3)."""
    frame = pd.DataFrame({"stream": "wheels", "t_s": [0.0, 2.0], "vel_l": 0.2, "vel_r": 0.2,
                          "cur_l": 5.0, "cur_r": 5.0})
    wheels = {"wheels": ("vel_l", "vel_r", "cur_l", "cur_r")}
    with pytest.raises(DataFormatError, match="implies 0.5 Hz, outside its nominal"), \
            pytest.warns(DataWarning, match="timestamp_units"):
        parse_request(frame, wheels, 2.0, 10_000)
