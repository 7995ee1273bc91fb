"""The closed loop's sample and call schedules do not drift: the n-th sample of a sensor (and
the n-th call of the controller) falls at n / rate however long the run, with no sample lost
to rounding."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from terrain.sim import DEFAULT_SENSORS
from terrain.sim.closed_loop import OnlineSensors, make_hook


class _Quiet:
    """Sensors stand-in: records nothing, hands back the call time."""

    def record(self, snap):
        return None

    def take(self, t_s, omega_low_level):
        return t_s


def test_a_controller_at_the_physics_rate_is_called_on_every_step_of_a_long_run():
    # 100 Hz controller on 100 Hz physics for 2300 s: the running sum of 0.01 s periods
    # drifted past the 1e-9 s tolerance at 2172.52 s and that call was skipped
    calls = []
    hook = make_hook(_Quiet(), calls.append, 100.0)
    t = np.arange(230_001) * 0.01
    for tk in t:
        hook(SimpleNamespace(t_s=float(tk), omega_low_level=None))
    assert len(calls) == len(t)
    assert calls[217_252] == t[217_252]


def test_a_sensor_channel_samples_every_step_of_a_long_run():
    s = OnlineSensors("husky", DEFAULT_SENSORS["husky"], 0, 1.0)
    imu = s.ch["imu"]                     # 100 Hz, as the physics
    t = np.arange(230_001) * 0.01
    due = sum(imu.due(float(tk)) for tk in t)
    assert due == len(t)
