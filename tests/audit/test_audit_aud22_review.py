"""Metamorphic properties of the audit (aud22): run order, run names, clock shifts, planted
effect sizes, and the report's signal table against the residuals it summarises."""

from __future__ import annotations

import pytest

from audit_helpers import synthetic_frame
from terrain.audit import SelectionSettings
from terrain.audit.selection import select_group

CI = SelectionSettings(n_bootstrap=100, n_param_bootstrap=10)


def _chi_frames(seed: int, chi: float | None, n: int = 4, terrain: str = "ASPHALT",
                prefix: str = "run"):
    return [synthetic_frame(f"{prefix}{i}", terrain=terrain, chi=chi, seed=seed * 10 + i,
                            n_cycles=2)
            for i in range(n)]


@pytest.mark.parametrize("perm", [(3, 2, 1, 0), (1, 3, 0, 2)])
def test_the_gain_and_parameter_intervals_do_not_depend_on_the_order_of_the_runs(perm):
    # the bootstraps drew unit positions: the same runs listed in another order got another
    # interval (gyro_bias's gain interval (-7.1e-05, -1.6e-05) reversed (-6.8e-05, -1.0e-05))
    # and, near the rule's edge, another verdict
    frames = _chi_frames(1, 1.6)
    a = select_group([[f] for f in frames], "yaw", "ASPHALT", CI)
    b = select_group([[frames[i]] for i in perm], "yaw", "ASPHALT", CI)
    assert b.selected == a.selected == ("icr_expansion",)
    for ea, eb in zip(a.effects, b.effects):
        assert eb.heldout_gain_ci95 == ea.heldout_gain_ci95, ea.name
        assert eb.ci95 == ea.ci95, ea.name
        assert eb.supported == ea.supported
    assert [u[0].run_id for u in b.units] == [u[0].run_id for u in a.units]


def test_pooled_intervals_do_not_depend_on_the_order_of_the_terrains():
    frames = (_chi_frames(2, 1.6, n=3) + _chi_frames(3, 1.8, n=3, terrain="ICE",
                                                     prefix="ice/run"))
    a = select_group([[f] for f in frames], "yaw", "all", CI)
    b = select_group([[f] for f in frames[3:] + frames[:3]], "yaw", "all", CI)
    assert [e.as_dict() for e in b.effects] == [e.as_dict() for e in a.effects]
