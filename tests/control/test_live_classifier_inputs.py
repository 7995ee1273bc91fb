"""pipelines/live_terrain.py without a trained model: which samples of the loop reach the
classifier, when its decisions become available, and where it applies.

A recording stand-in of the fitted pipeline sees the windows the streaming service builds
from the loop's observations, so the mapping from the loop's sensors (wheel encoders in
rad/s, per-side motor currents, the full IMU) to the model's channels (``vel_l = omega_l
r``, ...) is checked against known values.
"""

from __future__ import annotations

import numpy as np
import pytest
from control_helpers import observation

from features.windows import WindowConfig
from pipelines.live_terrain import LiveClassifier, classifier_applies, live_decisions
from terrain.errors import DataFormatError
from terrain.serving.model import StreamModel
from terrain.vehicles import HUSKY

CHANNELS = ("wx", "wy", "wz", "ax", "ay", "az", "vel_l", "vel_r", "cur_l", "cur_r")
#: the loop's wheel samples: 0.15 s apart from 0.07 s, so none falls on a window's end
WHEEL_T0_S, WHEEL_DT_S = 0.07, 0.15
OMEGA_L, OMEGA_R, CUR_L, CUR_R = 3.0, 4.0, 1.0, 2.0          # rad/s, rad/s, A, A


class RecordingPipeline:
    """Fitted-classifier stand-in: keeps every window it is given, answers ``proba``."""

    def __init__(self, classes=("ICE", "SNOW"), proba=(0.2, 0.8)):
        self.classes_ = np.asarray(classes)
        self.proba = np.asarray(proba, float)
        self.windows: list[np.ndarray] = []

    def predict_proba(self, X):
        self.windows.append(np.array(X))
        return np.tile(self.proba, (len(X), 1))


def _model(metadata=None, classes=("ICE", "SNOW")) -> StreamModel:
    return StreamModel(RecordingPipeline(classes), CHANNELS,
                       WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=50.0), classes,
                       {"vehicle": "husky", "hop_s": 0.5} if metadata is None else metadata)


def _observations(duration_s: float, imu_silent=(np.inf, np.inf)):
    """Loop calls every 0.02 s with the samples taken since the previous call: IMU at
    100 Hz (none inside ``imu_silent``), wheels and currents at the same times."""
    t_imu = np.arange(0.0, duration_s, 0.01)
    t_imu = t_imu[(t_imu < imu_silent[0]) | (t_imu >= imu_silent[1])]
    t_wheel = np.arange(WHEEL_T0_S, duration_s, WHEEL_DT_S)
    calls = np.arange(0.02, duration_s + 1e-9, 0.02)
    prev = -np.inf
    for t in calls:
        ti = t_imu[(t_imu > prev) & (t_imu <= t + 1e-9)]
        tw = t_wheel[(t_wheel > prev) & (t_wheel <= t + 1e-9)]
        imu_full = np.column_stack([ti, np.full((len(ti), 5), 0.1), np.full(len(ti), 9.81)])
        wheels = np.column_stack([tw, np.full(len(tw), OMEGA_L), np.full(len(tw), OMEGA_R)])
        currents = np.column_stack([tw, np.full(len(tw), CUR_L), np.full(len(tw), CUR_R)])
        prev = t
        yield observation(float(t), [OMEGA_L, OMEGA_R], wheels=wheels, currents=currents,
                          imu_full=imu_full)


def _fed(model, observations) -> LiveClassifier:
    live = LiveClassifier(model, "husky")
    for obs in observations:
        live.update(obs)
    return live


def test_the_model_sees_rim_speeds_and_each_sides_current_in_its_own_channel():
    model = _model()
    live = _fed(model, _observations(4.0))
    assert live.n_windows >= 3 and len(model.pipeline.windows) == live.n_windows
    window = model.pipeline.windows[0][0]                      # (channels, samples)
    by_name = dict(zip(CHANNELS, window))
    r = HUSKY.wheel_radius_m
    np.testing.assert_allclose(by_name["vel_l"], OMEGA_L * r)  # m/s from rad/s
    np.testing.assert_allclose(by_name["vel_r"], OMEGA_R * r)
    np.testing.assert_allclose(by_name["cur_l"], CUR_L)
    np.testing.assert_allclose(by_name["cur_r"], CUR_R)
    np.testing.assert_allclose(by_name["az"], 9.81)


def test_a_decision_is_available_from_the_loop_time_it_was_emitted():
    """The aligned clock starts at the first wheel sample (0.07 s), so the first window is
    [0.07, 2.07) s; it is complete only once a wheel sample at or after its end arrives,
    at 2.17 s: the loop must not see its decision before, although the window ends at
    2.07 s."""
    live = _fed(_model(), _observations(3.0))
    first_wheel_after = WHEEL_T0_S + 14 * WHEEL_DT_S                # 2.17 s
    assert live(2.1) == (None, 0.0) and live(first_wheel_after - 0.01) == (None, 0.0)
    label, confidence, t_decided = live(first_wheel_after + 0.02)
    assert label == "SNOW" and confidence == pytest.approx(0.8)
    assert first_wheel_after - 1e-9 <= t_decided <= first_wheel_after + 0.02


def test_a_window_the_service_did_not_classify_is_no_decision():
    # the IMU is silent over [0.5, 1) s: the first two windows hold the gap and are not
    # classified (no decision yet: no label, confidence 0); the third is
    live = _fed(_model(), _observations(4.0, imu_silent=(0.5, 1.0)))
    assert live.n_windows >= 3
    assert live(2.3) == (None, 0.0) and live(2.9) == (None, 0.0)
    assert live(3.3)[:2] == ("SNOW", pytest.approx(0.8))


def test_wheel_and_current_samples_at_different_times_are_refused():
    live = LiveClassifier(_model(), "husky")
    wheels = np.array([[0.1, OMEGA_L, OMEGA_R]])
    with pytest.raises(DataFormatError, match="different times"):
        live.update(observation(0.2, [OMEGA_L, OMEGA_R], wheels=wheels,
                                currents=np.array([[0.11, CUR_L, CUR_R]])))


@pytest.mark.parametrize("metadata, vehicle, terrain, applies", [
    ({"vehicle": "husky"}, "husky", "snow", True),        # a terrain in any case
    ({"vehicle": "husky"}, "husky", "GRASS", False),      # not one of the model's classes
    ({"vehicle": "husky"}, "agrimaro", "SNOW", False),    # trained on another vehicle
    ({"dataset": "borealtc"}, "husky", "ICE", True),      # the Husky recorded BorealTC
    ({"dataset": "borealtc"}, "agrimaro", "ICE", False),
])
def test_the_classifier_applies_to_its_own_vehicle_and_classes(metadata, vehicle, terrain,
                                                               applies):
    model = _model(metadata)
    ok, note = classifier_applies(model, vehicle, terrain)
    assert ok is applies
    live, table, note2 = live_decisions(model, vehicle, terrain)
    assert note2 == note
    if applies:
        assert isinstance(live, LiveClassifier) and "loop's own samples" in note
        # the desired-slip table spans the model's classes, not the run's terrain alone
        assert sorted(table.entries) == ["ICE", "SNOW"]
    else:
        assert live is None and table is None and "comes from the label" in note


def test_decision_hop_of_a_train_model_without_one_is_the_streaming_default():
    """A ``terrain train`` model stores ``hop_s: null`` (its batch windows back to back): the
    live classifier then decides every 0.5 s, the streaming service's default and ``terrain
    stream --hop-s``'s (README, control-sim); a hop the model names is taken as it is,
    from its metadata first, else from its window."""
    from pipelines.live_terrain import decision_hop_s
    from terrain.serving.service import StreamConfig

    def model(metadata, hop_s):
        return StreamModel(RecordingPipeline(), CHANNELS,
                           WindowConfig(window_s=2.0, hop_s=hop_s, rate_hz=50.0),
                           ("ICE", "SNOW"), metadata)

    assert StreamConfig().hop_s == 0.5
    assert decision_hop_s(model({"vehicle": "husky", "hop_s": None}, None)) == 0.5
    assert decision_hop_s(model({"vehicle": "husky"}, None)) == 0.5
    assert decision_hop_s(model({"vehicle": "husky"}, 1.0)) == 1.0
    assert decision_hop_s(model({"vehicle": "husky", "hop_s": 0.25}, 1.0)) == 0.25
    # and the classifier's streaming service decides at that hop
    assert LiveClassifier(model({"hop_s": None}, None), "husky").service.config.hop_s == 0.5
