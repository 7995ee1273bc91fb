"""Review tests of the audit's effects, its sample table and its report (auditfx pass)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit import AuditSettings, SelectionSettings, run_audit
from terrain.audit.effects import predict_yaw
from terrain.audit.report import signal_table
from terrain.audit.selection import loro

FAST = AuditSettings(selection=SelectionSettings(n_bootstrap=200, n_param_bootstrap=20),
                     pooled=False)


def _pooled_rmse(pairs):
    r = np.concatenate([m - p for m, p in pairs])
    return float(np.sqrt(np.mean(r * r)))


@pytest.fixture(scope="module")
def chi_audit():
    """Four synthetic runs of a robot turning 1.5 times slower than ideal drive (the
    replay's chi is 1.2), measured lateral acceleration ``v wz``, audited."""
    frames = []
    for i in range(4):
        f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, noise=0.002)
        frames.append(replace(f, ay=f.commanded_speed * f.commanded_yaw_rate / 1.5,
                              sim_ay=f.sim_vx * f.sim_wz))
    return frames, run_audit([], FAST, frames=frames)


def test_the_extended_lateral_acceleration_follows_the_fitted_yaw_rate(chi_audit):
    """A robot turning 1.5 times slower than ideal drive (chi 1.5, the replay's 1.2): its
    lateral acceleration is ``v wz``. The extended model's ``ay`` is the replay's plus
    ``(wz_ext - wz_replay) v``, so it moves towards the measured one and its error is the
    hand-computed one."""
    frames, result = chi_audit
    assert "icr_expansion" in result.supported("ASPHALT")
    table = signal_table(result).set_index("signal")
    units = [[f] for f in frames]
    spec = list(result.groups[("ASPHALT", "yaw")].selected)
    held = loro(units, "yaw", spec, [], result.settings.effects)
    m = [f.score_imu for f in frames]
    ext = _pooled_rmse(
        (f.ay[k], (f.sim_ay + (predict_yaw(f, p) - p.bias_rad_s - f.sim_wz) * f.sim_vx)[k])
        for f, k, p in zip(frames, m, held))
    rep = _pooled_rmse((f.ay[k], f.sim_ay[k]) for f, k in zip(frames, m))
    assert table.loc["ay", "replay_rmse"] == pytest.approx(rep, rel=1e-9)
    assert table.loc["ay", "extended_rmse"] == pytest.approx(ext, rel=1e-9)
    assert table.loc["ay", "extended_rmse"] < 0.5 * table.loc["ay", "replay_rmse"]
