"""Review sim21: the closed loop's online encoder against the batch encoder model.

:class:`terrain.sim.closed_loop.OnlineSensors` and the batch streams of
:func:`terrain.sim.simulate.simulate_with_physics` compute the AgriMaRo's reported wheel
speed two ways (count rate per physics step, then the motor driver's first-order filter):
one sample at a time and over the whole run. On the same physics steps they must agree.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.sim.closed_loop import OnlineSensors
from terrain.sim.dynamics import PlantSnapshot
from terrain.sim.sensors import encoder_count_rate, first_order_filter
from terrain.sim.simulate import DEFAULT_SENSORS

DT_S = 0.01


def _online_and_batch(omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Wheel samples (50 Hz) of the online encoder and the batch model at 100 Hz physics."""
    sensors = OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 0, 2.0)
    motor = sensors.vehicle.motor
    z = np.zeros(3)
    for k, om in enumerate(omega):
        sensors.record(PlantSnapshot(k, DT_S * k, z, z, np.zeros(2), om, z, om, z))
    online = sensors.take(DT_S * (len(omega) - 1), z).wheels[:, 1:]
    batch = first_order_filter(encoder_count_rate(omega, DT_S, motor.encoder_counts_per_rev),
                               DT_S, motor.encoder_filter_s)
    return online, batch[::2]


@settings(max_examples=25, deadline=None)
@given(rates=st.lists(st.floats(-300.0, 300.0, allow_nan=False), min_size=2, max_size=60))
def test_online_encoder_is_the_batch_model_for_a_wheel_starting_at_rest(rates):
    """Any speed profile from rest (accelerations in rad/s^2 per step): the same samples."""
    omega = np.repeat(np.concatenate([[0.0], np.cumsum(rates) * DT_S])[:, None], 3, axis=1)
    online, batch = _online_and_batch(omega)
    np.testing.assert_allclose(online, batch, rtol=0, atol=1e-9)


def test_online_encoder_is_the_batch_model_for_a_wheel_already_turning_on_the_first_step():
    omega = np.column_stack([np.linspace(3.0, 12.0, 101)] * 3)
    online, batch = _online_and_batch(omega)
    np.testing.assert_allclose(online, batch, rtol=0, atol=1e-9)
