"""Planted effects in simulated runs: the audit must name each one, with its magnitude, and
name nothing when nothing is planted.

Each case simulates three 60 s Husky runs on ASPHALT (``random`` scenario, seeds
:data:`SIM_SEEDS`), plants one effect at a moderate magnitude (by the simulator, or by
modifying the signal files for ``immobilised`` and ``grade_resistance``), writes only the
``imu_`` and ``pro_`` files and audits the folder. Tolerances are stated per case; for
``icr_expansion`` and ``turning_resistance`` the parameter is compared with the null audit of
the same seeds (the simulated physics has its own lateral scrub and turning current).
"""

from __future__ import annotations

import numpy as np
import pytest

from audit_helpers import (SIM_SEEDS, audit_folder, plant_grade, plant_immobilised,
                           simulated_streams, write_signal_files)
from terrain.audit import EFFECT_NAMES

TERRAIN = "ASPHALT"


def _audit_planted(audit_tmp, name, effects=None, modify=None):
    streams = simulated_streams(effects)
    root = audit_tmp(name)
    for i, (imu, pro) in enumerate(streams):
        if modify is not None:
            imu, pro = modify(imu, pro, np.random.default_rng(1000 + SIM_SEEDS[i]))
        write_signal_files(root, TERRAIN, i, imu, pro)
    return audit_folder(root)


def _param(result, name):
    return result.effect(name, TERRAIN).params


def test_null_case_names_nothing(sim_null):
    result, _ = sim_null
    assert result.supported(TERRAIN) == []
    names = {e.name for e in result.effects() if e.terrain == TERRAIN}
    assert names == set(EFFECT_NAMES)                  # every effect was examined
    assert abs(_param(result, "gyro_bias")["bias_rad_s"]) < 0.003
    assert abs(_param(result, "wheel_lag")["lag_s"]) < 0.05
    assert abs(_param(result, "current_offset")["offset_a"]) < 0.1
    assert _param(result, "immobilised")["fraction"] < 0.05


@pytest.mark.parametrize("name, effects, modify, expected, tol", [
    ("gyro_bias", {"gyro_bias": 0.02}, None, {"bias_rad_s": 0.02}, 0.005),
    ("wheel_lag", {"wheel_lag": 0.5}, None, {"lag_s": 0.5}, 0.15),
    ("current_offset", {"current_offset": 1.5}, None, {"offset_a": 1.5}, 0.2),
    ("immobilised", None, lambda imu, pro, rng: (plant_immobilised(imu, pro, 0.3, rng), pro),
     {"fraction": 0.3}, 0.1),
    ("grade_resistance", None, lambda imu, pro, rng: plant_grade(imu, pro, 10.0, rng),
     {"k_a_per_rad": 10.0}, 2.0),
])
def test_planted_effect_is_named_with_its_magnitude(audit_tmp, name, effects, modify,
                                                    expected, tol):
    result = _audit_planted(audit_tmp, f"sim_{name}", effects, modify)
    assert result.supported(TERRAIN) == [name]         # found, and nothing else
    e = result.effect(name, TERRAIN)
    assert e.heldout_gain > 0.05 and e.heldout_gain_ci95[0] > 0
    for k, v in expected.items():
        assert e.params[k] == pytest.approx(v, abs=tol), (name, e.params)


@pytest.mark.slow
def test_planted_icr_expansion_relative_to_null(audit_tmp, sim_null):
    null, _ = sim_null
    result = _audit_planted(audit_tmp, "sim_icr", {"icr_expansion": 1.5})
    assert "icr_expansion" in result.supported(TERRAIN)
    assert set(result.supported(TERRAIN)) <= {"icr_expansion"}
    chi_null = _param(null, "icr_expansion")["chi"]
    assert 1.0 <= chi_null < 1.15                      # the physics' own scrub
    assert _param(result, "icr_expansion")["chi"] / chi_null == pytest.approx(1.5, abs=0.08)
    assert result.effect("icr_expansion", TERRAIN).heldout_gain > 0.5


@pytest.mark.slow
def test_planted_turning_resistance_relative_to_null(audit_tmp, sim_null):
    null, _ = sim_null
    result = _audit_planted(audit_tmp, "sim_turning", {"turning_resistance": 2.0})
    assert result.supported(TERRAIN) == ["turning_resistance"]
    e = result.effect("turning_resistance", TERRAIN)
    assert e.details["form"] == "coulomb"              # the simulator plants tanh(|r|/0.1)
    k_null = _param(null, "turning_resistance")["k_a"]
    assert e.params["k_a"] - k_null == pytest.approx(2.0, abs=0.4)
    lo, hi = e.ci95["k_a"]
    assert lo < e.params["k_a"] < hi
