"""Review ctl24: arguments of the closed loop and its estimators that were taken and failed
only at the first call (a bare TypeError or AttributeError), stopped on a bare Python error,
or were read as another value unsaid (a bytes label given the fallback) now get a named
:class:`~terrain.errors.ConfigError`; valid ones are unchanged."""

import numpy as np
import pytest

from terrain.control import build_slip_table, config_for_vehicle
from terrain.control.closed_loop import TractionLoop
from terrain.control.desired_slip import select_target
from terrain.control.estimators import (AgriMaRoVisualOdometryEKF, FusedSlipObserver,
                                        WheelImuObserver, estimator_for)
from terrain.errors import ConfigError


def _loop(**changes):
    cfg, n = config_for_vehicle("husky", kp=2.0)
    args = {"estimator": WheelImuObserver(), "table": build_slip_table(["ICE"]),
            "terrain_decision": lambda t: ("ICE", 1.0), **changes}
    return TractionLoop(cfg, n, **args)


@pytest.mark.parametrize("name, value", [("terrain_decision", "ICE"),
                                         ("terrain_decision", ("ICE", 1.0)),
                                         ("observer", 5), ("estimator", None),
                                         ("estimator", "fused")])
def test_loop_refuses_an_argument_it_cannot_call(name, value):
    with pytest.raises(ConfigError, match=name):
        _loop(**{name: value})


def test_loop_of_valid_callables_runs():
    seen = []
    loop = _loop(observer=seen.append)
    from control_helpers import observation
    out = loop(observation(0.0, np.zeros(2)))
    assert out.tolist() == [0.0, 0.0] and len(seen) == 1


@pytest.mark.parametrize("label", [b"ICE", np.array(["ICE"]), 5, ["ICE"]])
def test_select_target_refuses_a_label_that_is_not_text(label):
    with pytest.raises(ConfigError, match="terrain"):
        select_target(build_slip_table(["ICE", "TILES"]), label)


@pytest.mark.parametrize("label, entry", [("tiles", "TILES"), (np.str_("TILES"), "TILES"),
                                          (None, None), ("GRASS", None)])
def test_select_target_of_text_labels_is_unchanged(label, entry):
    table = build_slip_table(["ICE", "TILES"])
    expected = table.fallback if entry is None else table.entries[entry]
    assert select_target(table, label) is expected


@pytest.mark.parametrize("vehicle", [["husky"], {"husky": 1}])
def test_estimator_for_refuses_a_vehicle_that_is_not_text(vehicle):
    with pytest.raises(ConfigError, match="vehicle"):
        estimator_for(vehicle)


@pytest.mark.parametrize("std", ["a", None, [0.8]])
def test_agrimaro_ekf_refuses_an_accelerometer_std_that_is_not_a_number(std):
    with pytest.raises(ConfigError, match="accel_std_m_s2"):
        AgriMaRoVisualOdometryEKF(accel_std_m_s2=std)


@pytest.mark.parametrize("decision", [5, "ICE", ("ICE", 1.0)])
def test_fused_observer_refuses_a_terrain_decision_that_is_not_a_function(decision):
    with pytest.raises(ConfigError, match="terrain_decision"):
        FusedSlipObserver("husky", decision)


def test_fused_observer_of_a_function_or_none_is_built():
    assert FusedSlipObserver("husky", None).terrain_decision is None
    f = lambda t: ("ICE", 1.0)   # noqa: E731
    assert FusedSlipObserver("husky", f).terrain_decision is f
