"""Review ctl21: the control layer at its boundaries (values exactly at a threshold, a limit
or a range end, and one ulp either side)."""

from types import MappingProxyType

import numpy as np
import pytest

from terrain.control.closed_loop import TractionLoop
from terrain.control.desired_slip import (DesiredSlip, DesiredSlipConfig, SlipTable,
                                          fallback_entry)
from terrain.control.estimators import VelocityEstimate
from terrain.control.traction import TractionControlConfig

from tests.control.control_helpers import observation


class _Spinning:
    """Both sides spinning: rim 1.0 m/s (10 rad/s at r 0.1 m) on ground at 0.5 m/s."""

    name = "spinning"
    limits = "fixed"

    def update(self, obs):
        return VelocityEstimate(np.full(2, 10.0), np.full(2, 0.5), np.zeros(2), 0.5, 0.0)


def _table(traction: float) -> SlipTable:
    """A hand-built table of one catalogued class (ICE) with the given traction target."""
    entry = DesiredSlip("ICE", traction, -0.5, 0.0, "hand-built", "test")
    return SlipTable(MappingProxyType({"ICE": entry}), fallback_entry([entry]),
                     DesiredSlipConfig())


@pytest.mark.parametrize("traction", [1.0, float(np.nextafter(1.0, 0.0)), 0.5])
def test_loop_runs_with_a_traction_target_at_the_top_of_its_range(traction):
    """A DesiredSlip's traction target is in (0, 1] (check_slip_targets): 1 is a valid
    target. With the feed-forward on (the default) the loop handed it to feedforward_step,
    which refuses |target_slip| >= 1: the first call of a loop on a hand-built table
    whose target is 1 stopped on a ConfigError. At 1 no ground speed limits the wheel:
    no feed-forward correction; just below it the limit is a finite wheel speed."""
    loop = TractionLoop(TractionControlConfig(kp=1.0, wheel_radius_m=0.1), 2, _Spinning(),
                        _table(traction), lambda t: ("ICE", 1.0))
    for k in range(5):
        corr = loop(observation(0.02 * k, np.full(2, 10.0)))
        assert corr.shape == (2,) and np.all(np.isfinite(corr))
    if traction == 1.0:
        assert not loop.ff_engaged.any()
        # the feedback alone: slip 0.5 against a target of 1 leaves the wheel as it is
        assert np.all(corr == 0.0)
