"""Review srv19 of pipelines/live_terrain.py: a window the streaming service did not
classify after a first decision (a timestamp gap of the IMU) is no decision for the loop."""

from __future__ import annotations

import pytest
from test_live_classifier_inputs import _fed, _model, _observations  # same folder

from terrain.control.desired_slip import build_slip_table, select_target


def test_an_unclassified_window_after_a_decision_is_no_decision():
    """The IMU is silent over [3, 3.5) s: the windows holding that gap are not classified
    (flag ``gap``). Without smoothing the service keeps the previous class with the uniform
    probabilities (0.5 of two classes) there; the live classifier passed that on as a fresh
    ``("SNOW", 0.5, t)``, which a table with ``min_confidence`` 0.5 trusts, so a gapped IMU
    kept renewing the last decision instead of leaving it to age into the fallback."""
    live = _fed(_model(), _observations(6.0, imu_silent=(3.0, 3.5)))
    assert live(2.9)[:2] == ("SNOW", pytest.approx(0.8))
    # windows [t - 2, t) holding [3, 3.5): emitted between about 3.5 s and 5.5 s
    for t in (3.7, 4.1, 4.5, 4.9, 5.3):
        assert live(t) == (None, 0.0), t
    assert live(5.99)[:2] == ("SNOW", pytest.approx(0.8))   # a whole window after the gap


def test_the_loop_gets_the_fallback_while_the_windows_are_not_classified():
    live = _fed(_model(), _observations(6.0, imu_silent=(3.0, 3.5)))
    table = build_slip_table(["ICE", "SNOW"])
    label, confidence, *rest = live(4.1) + (None,)
    age = None if rest[0] is None else 4.1 - rest[0]
    assert select_target(table, label, confidence, age) == table.fallback
