"""Without the forward filter's memory (``dwell_s=None``), a window the service did not
classify is no evidence: its uniform probabilities (1/K) must never be trusted, even where
1/K reaches ``min_confidence`` (two classes, 0.5; srv19's left-alone, stop 92)."""

from __future__ import annotations

import numpy as np

from features.windows import WindowConfig
from terrain.serving import SmoothingConfig, StreamConfig, StreamModel, StreamService
from terrain.serving.targets import TableTargets

CLASSES = ("ICE", "SNOW")


class _Const:
    classes_ = np.array(CLASSES)

    def predict_proba(self, X):
        return np.tile([0.2, 0.8], (len(X), 1))


def _decisions(dwell_s):
    model = StreamModel(_Const(), ("vel_l", "vel_r"), WindowConfig(window_s=1.0, rate_hz=8.0),
                        CLASSES)
    targets = TableTargets(CLASSES)
    svc = StreamService(model, targets, StreamConfig(
        hop_s=0.5, streams={"wheels": ("vel_l", "vel_r")}, min_confidence=0.5,
        smoothing=SmoothingConfig(dwell_s=dwell_s)))
    t = 100 + np.arange(40) / 8
    t = np.r_[t[:24], t[30:]]      # a hole of 0.75 s: the windows across it are gaps
    out = []
    for ti in t:
        out += svc.push("wheels", np.array([ti]), np.zeros((1, 2)))
    return out, targets


def test_an_unclassified_window_without_memory_gets_the_conservative_target():
    decided, targets = _decisions(None)
    gaps = [d for d in decided if "gap" in d.flags.split("|")]
    assert gaps and any("gap" not in d.flags for d in decided)
    fallback = targets.target_for(None, 0.5, False)
    for d in gaps:
        assert d.confidence == 0.5 and d.terrain == "SNOW" and d.flags == "gap", d
        assert (d.target_slip_traction, d.target_slip_braking, d.target_slip_steady) == \
            tuple(float(x) for x in fallback), d
    snow = targets.target_for("SNOW", 0.8, False)
    for d in decided:
        if "gap" not in d.flags:
            assert d.target_slip_traction == float(snow.traction), d


def test_with_memory_a_gap_is_predicted_and_still_trusted():
    """With the filter, a gap window is a prediction step from a confident past: trusted
    (the smoothing's design), so only the no-memory case changes."""
    decided, targets = _decisions(10.0)
    gaps = [d for d in decided if "gap" in d.flags.split("|")]
    assert gaps and all(d.confidence > 0.5 and "low_confidence" not in d.flags for d in gaps)
