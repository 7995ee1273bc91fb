"""Audit review (aud21): run ids of the runs given beside prepared frames, and the
ceiling and gain tables on samples a model column covers only in part."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from audit_helpers import synthetic_frame
from terrain.audit import AuditSettings, run_audit
from terrain.audit.selection import SelectionSettings
from terrain.errors import ConfigError

SETTINGS = AuditSettings(selection=SelectionSettings(n_bootstrap=50, n_param_bootstrap=0),
                         pooled=False)


def test_runs_sharing_a_run_id_beside_prepared_frames_are_refused():
    # before: with the frames given, only the frames' ids were checked, so two runs of one
    # id (one replayed into the frame, its twin skipped by the caller) passed, and the
    # lateral-friction sweep replayed both under that one id
    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i) for i in range(3)]
    runs = [SimpleNamespace(run_id="s/ASPHALT/0"), SimpleNamespace(run_id="s/ASPHALT/0")]
    with pytest.raises(ConfigError, match=r"run ids must be unique.*s/ASPHALT/0 \(2 runs\)"):
        run_audit(runs, SETTINGS, frames=frames)
