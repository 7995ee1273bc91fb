"""Review tests (aud11) of terrain.audit: the reason given when the replay leaves nothing to
remove, and mutants of the selection and effect fits that the earlier tests let through."""

from __future__ import annotations

from audit_helpers import synthetic_frame
from terrain.audit.selection import SelectionSettings, select_group

FAST = SelectionSettings(n_bootstrap=100, n_param_bootstrap=0)


def _units(n=4, **kw):
    return [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, **kw)] for i in range(n)]


def test_a_replay_without_error_is_not_reported_as_having_no_samples():
    # a gyro that reads the replay exactly (noise 0): every turning sample is scored, the
    # replay leaves nothing to remove; the reason said "no scored samples in scope 'turning'"
    g = select_group(_units(noise=0.0), "yaw", "ASPHALT", FAST)
    assert g.selected == ()
    for e in g.effects:
        assert not e.supported
        assert "no scored samples" not in e.reason
        assert "no error" in e.reason and "scored samples" in e.reason
