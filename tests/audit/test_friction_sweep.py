"""The audit's what-if sweep of the catalogue lateral friction (``lateral_friction_sweep``).

A skid-steer robot scrubs its tyres sideways in every turn: the more lateral friction the
contact model has, the more the replayed robot resists turning and the larger its ICR
expansion chi (the replayed yaw rate falls short of ``(v_R - v_L) / B``). The table is
scored on the samples the audit's frames score (``edge_s`` from either end of the record).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from terrain.audit import AuditSettings
from terrain.audit.core import lateral_friction_sweep
from terrain.audit.report import matching_lateral_friction
from terrain.errors import ConfigError
from terrain.run import Run
from terrain.sim import SimConfig, simulate
from terrain.terramechanics.catalogue import get_terrain

FACTORS = (0.5, 1.0, 2.0)


@pytest.fixture(scope="module")
def sandy_run() -> Run:
    return simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",), scenario="random",
                              duration_s=30.0, seed=3))


def _turning_at_the_end(run: Run, last_s: float) -> Run:
    """The run with its wheels spinning in place (left back, right forward, 1 m/s) over its
    last ``last_s`` seconds: more turning samples, all inside the record's end edge."""
    wheels = run.streams["wheels"].copy()
    end = wheels.t_s >= wheels.t_s.iloc[-1] - last_s
    wheels.loc[end, "vel_l"], wheels.loc[end, "vel_r"] = -1.0, 1.0
    return replace(run, streams={**run.streams, "wheels": wheels})


@pytest.mark.slow
def test_replayed_chi_rises_with_the_lateral_friction(sandy_run):
    table = lateral_friction_sweep([sandy_run], "SANDY_LOAM", FACTORS, measured_chi=1.7)
    base = get_terrain("SANDY_LOAM").lateral_friction
    np.testing.assert_allclose(table.lateral_friction, np.array(FACTORS) * base)
    assert table.n_runs.tolist() == [1, 1, 1] and (table.measured_chi == 1.7).all()
    chi = table.replay_chi.to_numpy()
    assert chi[0] >= 1.0 and np.all(np.diff(chi) > 0), chi


@pytest.mark.slow
def test_samples_within_the_edge_of_either_end_are_not_scored(sandy_run):
    settings = AuditSettings()
    assert settings.frames.edge_s == 2.0
    spun = _turning_at_the_end(sandy_run, last_s=0.8)
    as_run = lateral_friction_sweep([sandy_run], "SANDY_LOAM", (1.0,), settings)
    as_spun = lateral_friction_sweep([spun], "SANDY_LOAM", (1.0,), settings)
    assert as_spun.replay_chi[0] == pytest.approx(as_run.replay_chi[0], rel=1e-3)
    # the same spin inside the scored span does change the table
    longer = lateral_friction_sweep([_turning_at_the_end(sandy_run, last_s=6.0)],
                                    "SANDY_LOAM", (1.0,), settings)
    assert abs(longer.replay_chi[0] - as_run.replay_chi[0]) > 0.05


@pytest.mark.slow
def test_runs_of_other_terrains_or_without_turns_are_not_replayed(sandy_run):
    other = replace(sandy_run, terrain="SNOW")
    straight = sandy_run.streams["wheels"].copy()
    straight["vel_r"] = straight["vel_l"]
    table = lateral_friction_sweep([other, replace(sandy_run, streams={
        **sandy_run.streams, "wheels": straight})], "SANDY_LOAM", (1.0,))
    # unknown, not the inf of a replayed robot that digs in completely
    assert table.n_runs[0] == 0 and np.isnan(table.replay_chi[0])
    with pytest.raises(ConfigError, match="NO_SUCH"):
        lateral_friction_sweep([sandy_run], "NO_SUCH", (1.0,))


def _sweep(chi, measured):
    return pd.DataFrame({"lateral_friction": [0.2, 0.4, 0.8], "replay_chi": chi,
                         "measured_chi": measured})


@pytest.mark.parametrize("chi, measured, text", [
    ([1.2, 1.6, 3.0], 1.5, "~0.35"),           # 0.2 + (1.5 - 1.2) / (1.6 - 1.2) * 0.2
    ([1.2, 1.6, 3.0], 2.3, "~0.60"),
    # dug in at 0.8 (chi inf > 2.3): the match lies between 0.4 and 0.8, not above 0.8,
    # and there is nothing to interpolate towards
    ([1.2, 1.6, np.inf], 2.3, "between 0.4 and 0.8"),
    ([1.2, 1.6, 3.0], 1.6, "~0.40"),           # on a sweep point: that point's friction
    ([1.2, 1.6, 3.0], 1.2, "~0.20"),
    ([1.2, 1.6, 3.0], 3.0, "~0.80"),
    ([1.2, 1.6, 3.0], 1.1, "below 0.2"),
    ([1.2, 1.6, 3.0], 3.5, "above 0.8"),
    ([1.2, 1.6, 3.0], None, "-"),
    ([np.nan, np.nan, np.nan], 1.5, "-"),      # no run of the terrain turns
])
def test_matching_lateral_friction_interpolates_the_bracketing_points(chi, measured, text):
    assert matching_lateral_friction(_sweep(chi, measured)) == text
