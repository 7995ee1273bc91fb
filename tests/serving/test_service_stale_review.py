"""Review test of the streaming service's fallback on stale input: a confident decision
whose input is stale gets the provider's conservative targets, not its terrain's."""

from __future__ import annotations

import numpy as np
from test_service import _push_two_streams
from test_stream_scores import _WzClassifier

from features.windows import WindowConfig
from terrain.serving import (CataloguePeakTargets, SmoothingConfig, StreamConfig, StreamModel,
                             StreamService)


def test_a_confident_stale_decision_gets_the_fallback_target_and_its_own_terrain():
    # the IMU falls silent after 8 s: its windows are short from 9 s on and stale (over
    # stale_s = 1 s behind) from 9.5 s on; a slow filter (100 s dwell) keeps SNOW above
    # min_confidence through them, so only the stale rule can ask for the fallback
    classes = tuple(_WzClassifier.classes_)
    model = StreamModel(_WzClassifier(), ("vel_l", "wz"),
                        WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=8.0), classes)
    svc = StreamService(model, CataloguePeakTargets(classes, 0.5),
                        StreamConfig(hop_s=0.5, stale_s=1.0, min_confidence=0.5,
                                     smoothing=SmoothingConfig(dwell_s=100.0)))
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
