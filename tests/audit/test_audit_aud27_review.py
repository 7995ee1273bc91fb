"""Review aud27: the audit's seams with the readers, the simulator and the docs (units, sign
conventions, names): what one side produces, the other consumes alike."""

from __future__ import annotations

from dataclasses import replace

import pytest

from terrain.audit.core import AuditSettings, lateral_friction_sweep, prepare_frames
from terrain.sim import SimConfig, simulate


@pytest.fixture(scope="module")
def asphalt_run():
    """One 30 s simulated Husky run on ASPHALT (random scenario: turns both ways)."""
    return simulate(SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="random",
                              duration_s=30.0, seed=1))


@pytest.mark.parametrize("label", ["asphalt", "Asphalt"])
def test_the_friction_sweep_takes_a_run_labelled_in_another_case(asphalt_run, label):
    """A run read from a folder ``asphalt/`` carries the label ``asphalt``; the replay takes
    it (the catalogue's names are case-insensitive) and its frame says ``ASPHALT``, the
    terrain run_audit then sweeps. The sweep compared the run's label with that name as
    text, chose no run and wrote replay_chi NaN and n_runs 0 in the what-if table."""
    settings = AuditSettings()
    upper = asphalt_run
    lower = replace(asphalt_run, terrain=label)
    frames, _ = prepare_frames([lower], settings)
    assert frames[0].terrain == "ASPHALT"
    got = lateral_friction_sweep([lower], frames[0].terrain, (1.0,), settings)
    want = lateral_friction_sweep([upper], "ASPHALT", (1.0,), settings)
    assert got.n_runs.tolist() == [1]
    assert got.replay_chi.tolist() == want.replay_chi.tolist()
    # the terrain asked for in another case names the catalogue's terrain too
    again = lateral_friction_sweep([upper], label, (1.0,), settings)
    assert again.terrain.tolist() == ["ASPHALT"]
    assert again.replay_chi.tolist() == want.replay_chi.tolist()
