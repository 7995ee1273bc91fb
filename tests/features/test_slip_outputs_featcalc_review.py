"""slip_model_outputs review (featcalc): the run's pitch prior reaches the physics std."""

from __future__ import annotations

import numpy as np
import pytest

import features.slip_outputs as slip_outputs
from terrain.io.measured import read_runs_dir
from terrain.io.writer import write_run
from terrain.sim import SimConfig, simulate


@pytest.mark.slow
def test_the_physics_std_uses_the_runs_pitch_prior(tmp_path, monkeypatch):
    """The pseudo-measurement's load uncertainty takes the run's pitch prior
    (run_pitch_prior over its windows): a prior of a 0.3 rad slope instead of the level
    run's own must widen the physics std; the slip itself (from the window pitch) keeps
    its value (a call without the prior gave both runs the same std)."""
    write_run(simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",),
                                 scenario="straight_accel", duration_s=8.0, seed=3)), tmp_path)
    run = read_runs_dir(tmp_path, dataset="prior")[0]
    own = slip_outputs.slip_model_outputs(run)["physics"]
    monkeypatch.setattr(slip_outputs, "run_pitch_prior", lambda pitch, std: (0.3, 0.0))
    steep = slip_outputs.slip_model_outputs(run)["physics"]
    np.testing.assert_array_equal(steep[1], own[1])
    ok = np.isfinite(own[2]) & np.isfinite(steep[2])
    assert ok.any()
    assert (steep[2][ok] >= own[2][ok]).all() and (steep[2][ok] > own[2][ok]).any()
