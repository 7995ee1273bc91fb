"""State of the live classifier of the closed loop (aud24): an observation it refuses
leaves it as it was, so that the loop's next observations are decided as if the refused one
had never come."""

from __future__ import annotations

import numpy as np
import pytest

from features.windows import WindowConfig
from pipelines.live_terrain import LiveClassifier
from terrain.errors import DataFormatError
from terrain.serving.model import StreamModel
from terrain.sim.closed_loop import Observation

CHANNELS = ("wx", "wy", "wz", "ax", "ay", "az", "vel_l", "vel_r", "cur_l", "cur_r")


class _Pipeline:
    """Fitted-classifier stand-in: SNOW when the window's mean left current is above 1.5 A."""

    classes_ = np.asarray(["ICE", "SNOW"])

    def predict_proba(self, X):
        snow = np.asarray(X)[:, CHANNELS.index("cur_l")].mean(axis=1) > 1.5
        return np.column_stack([np.where(snow, 0.2, 0.9), np.where(snow, 0.8, 0.1)])


def _model() -> StreamModel:
    return StreamModel(_Pipeline(), CHANNELS, WindowConfig(window_s=1.0, hop_s=0.5,
                                                           rate_hz=50.0),
                       ("ICE", "SNOW"), {"vehicle": "husky", "hop_s": 0.5})


def _observation(t0: float, t1: float, cur_l: float, current_shift_s: float = 0.0,
                 wheel_dropout_s=(np.inf, np.inf)):
    """The samples of (t0, t1]: IMU at 100 Hz, wheels and currents at 20 Hz (none within
    ``wheel_dropout_s``)."""
    ti = np.arange(np.floor(t0 * 100) + 1, np.floor(t1 * 100 + 1e-6) + 1) / 100
    tw = ti[np.isclose((ti * 100) % 5, 0)]
    tw = tw[(tw < wheel_dropout_s[0]) | (tw >= wheel_dropout_s[1])]
    imu_full = np.column_stack([ti, np.full((len(ti), 5), 0.1), np.full(len(ti), 9.81)])
    wheels = np.column_stack([tw, np.full(len(tw), 3.0), np.full(len(tw), 4.0)])
    currents = np.column_stack([tw + current_shift_s, np.full(len(tw), cur_l),
                                np.full(len(tw), 1.0)])
    return Observation(t1, np.array([3.0, 4.0]), np.zeros((0, 4)), wheels, np.zeros((0, 3)),
                       np.zeros((0, 5)), currents, imu_full)


def _decisions(live: LiveClassifier, times) -> list:
    return [live(t) for t in times]


def test_an_observation_refused_leaves_the_live_classifier_as_it_was():
    # update pushed the observation's IMU samples into the streaming service before it
    # checked the wheel and current times: a refused observation left its IMU samples (and
    # the decisions they completed, dropped) in the service, and the same observation sent
    # again with its currents mended was refused as going back in time
    # the decisions: the wheels drop out over [1.5, 3.2) s, so the IMU's samples decide the
    # windows once the wheels have gone stale (1 s); the refused observation is the one the
    # wheels come back in
    calls = np.round(np.arange(0.0, 5.0, 0.1), 10)
    fresh, refused = LiveClassifier(_model(), "husky"), LiveClassifier(_model(), "husky")
    for t0, t1 in zip(calls[:-1], calls[1:]):
        cur_l = 1.0 if t1 < 2.0 else 2.0
        fresh.update(_observation(t0, t1, cur_l, wheel_dropout_s=(1.5, 3.2)))
        if t0 < 3.2 <= t1:
            with pytest.raises(DataFormatError, match="different times"):
                refused.update(_observation(t0, t1, cur_l, current_shift_s=0.001,
                                            wheel_dropout_s=(1.5, 3.2)))
        refused.update(_observation(t0, t1, cur_l, wheel_dropout_s=(1.5, 3.2)))
    times = np.arange(0.0, 5.0, 0.05)
    assert refused.n_windows == fresh.n_windows > 4
    assert _decisions(refused, times) == _decisions(fresh, times)
