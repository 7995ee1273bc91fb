"""StreamService refuses a target provider that would hand out its fallback unflagged."""

from __future__ import annotations

import pytest

from features.windows import WindowConfig
from terrain.control import DesiredSlipConfig
from terrain.errors import ConfigError
from terrain.serving import (CataloguePeakTargets, SmoothingConfig, StreamConfig, StreamModel,
                             StreamService, TableTargets)
from terrain.serving.targets import SlipTargets
from test_stream_scores import _WzClassifier

CLASSES = tuple(_WzClassifier.classes_)


def _service(targets, min_confidence=0.5):
    model = StreamModel(_WzClassifier(), ("vel_l", "wz"),
                        WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=8.0), CLASSES)
    return StreamService(model, targets, StreamConfig(hop_s=0.5, min_confidence=min_confidence,
                                                      smoothing=SmoothingConfig(dwell_s=None)))


@pytest.mark.parametrize("targets", [
    CataloguePeakTargets(CLASSES, min_confidence=0.6),
    TableTargets(CLASSES, DesiredSlipConfig(min_confidence=0.6)),
])
def test_a_provider_stricter_than_the_service_is_refused(targets):
    # before: a decision at confidence 0.55 was trusted by the service (no low_confidence
    # flag) and answered with the provider's fallback targets: nothing said why
    with pytest.raises(ConfigError, match=r"min_confidence 0\.6 is above the service's "
                                          r"min_confidence 0\.5"):
        _service(targets)


def test_a_provider_without_a_class_of_the_model_is_refused():
    with pytest.raises(ConfigError, match=r"no targets for the model's class\(es\) "
                                          r"\['SNOW'\]"):
        _service(CataloguePeakTargets([c for c in CLASSES if c != "SNOW"]))


def test_equal_or_laxer_providers_and_plain_providers_are_accepted():
    assert _service(CataloguePeakTargets(CLASSES, 0.5)).targets.min_confidence == 0.5
    assert _service(TableTargets(CLASSES), 0.8).targets.classes == CLASSES
    assert _service(CataloguePeakTargets(CLASSES, 0.0), 0.9) is not None

    class Fixed:       # a provider of the protocol's one method only: not checked
        def target_for(self, terrain, confidence, stale):
            return SlipTargets(0.1, -0.1, 0.05)
    assert isinstance(_service(Fixed()).targets, Fixed)
