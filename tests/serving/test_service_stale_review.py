"""Review tests of the streaming service on stale input: a confident decision whose input
is stale gets the provider's conservative targets, not its terrain's; a decision waiting
for a silent stream comes as soon as another stream is ``stale_s`` past it."""

from __future__ import annotations

import numpy as np
from test_service import _push_two_streams
from test_stream_scores import _WzClassifier

from features.windows import WindowConfig
from terrain.serving import (CataloguePeakTargets, SmoothingConfig, StreamConfig, StreamModel,
                             StreamService)


def _slow_filter_service() -> StreamService:
    """IMU and wheels at 8 Hz, 2 s windows, 0.5 s hop, ``stale_s`` 1 s, a 100 s dwell."""
    classes = tuple(_WzClassifier.classes_)
    model = StreamModel(_WzClassifier(), ("vel_l", "wz"),
                        WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=8.0), classes)
    return StreamService(model, CataloguePeakTargets(classes, 0.5),
                         StreamConfig(hop_s=0.5, stale_s=1.0, min_confidence=0.5,
                                      smoothing=SmoothingConfig(dwell_s=100.0)))


def test_a_confident_stale_decision_gets_the_fallback_target_and_its_own_terrain():
    # the IMU falls silent after 8 s: its windows are short from 9 s on and stale (over
    # stale_s = 1 s behind) from 9.5 s on; a slow filter (100 s dwell) keeps SNOW above
    # min_confidence through them, so only the stale rule can ask for the fallback
    svc = _slow_filter_service()
    decisions = _push_two_streams(svc, np.arange(0, 96) * 0.125, 8.0)
    snow, fallback = svc.targets.table["SNOW"], svc.targets.fallback
    assert snow.traction != fallback.traction
    short = [d for d in decisions if d.t_s == 9.0]
    stale = [d for d in decisions if d.t_s >= 9.5]
    assert len(short) == 1 and len(stale) >= 3
    # not stale yet: the terrain's own targets, though the window is not classified
    assert (short[0].terrain, short[0].flags) == ("SNOW", "short")
    assert short[0].target_slip_traction == snow.traction
    for d in stale:
        assert d.terrain == "SNOW" and d.confidence > 0.5 and d.flags == "short|stale"
        assert (d.target_slip_traction, d.target_slip_braking, d.target_slip_steady) == \
            (fallback.traction, fallback.braking, fallback.steady)


def test_a_decision_waiting_for_a_silent_stream_comes_once_another_is_stale_s_past_it():
    # the IMU falls silent after 8 s; the decision at t waits for it until the wheels
    # reach t + stale_s (1 s): 8.5 s comes with the wheel sample of 9.5 s, not one later
    svc = _slow_filter_service()
    came = {}
    for ti in np.arange(0, 96) * 0.125:
        for d in _push_two_streams(svc, [ti], 8.0):
            came[d.t_s] = ti
    assert [came[t] for t in (7.5, 8.0, 8.5, 9.0, 9.5)] == [7.5, 8.0, 9.5, 10.0, 10.5]
