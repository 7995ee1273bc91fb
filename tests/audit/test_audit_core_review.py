"""Review tests of the audit's core: ceiling, core, frames, physics and replay."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.audit.ceiling import online_current_samples, online_yaw_rate_samples
from terrain.audit.frames import MANOEUVRES, AuditFrame
from terrain.audit.timing import LagTrack
from terrain.errors import ConfigError

RATE_HZ = 6.5
STOP, STRAIGHT, SPIN = (MANOEUVRES.index(m) for m in ("stop", "straight", "spin"))


def _frame(run_id="a", chi=2.0, n_st=40, n_sp=80, n_stop=0, cycles=3):
    """Cycles of straight driving, spins in place and (``n_stop`` samples of) rest; the gyro
    turns at ``x / chi``, the replay at ``x / 3``, its right motor draws 0.5 A more than its
    left, the measured motors 1.5 A more than the replay's."""
    x = np.concatenate([np.r_[np.zeros(n_st), np.full(n_sp, 0.8), np.zeros(n_stop)]
                        for _ in range(cycles)])
    man = np.concatenate([np.r_[np.full(n_st, STRAIGHT), np.full(n_sp, SPIN),
                                np.full(n_stop, STOP)] for _ in range(cycles)])
    v = np.where(man == STRAIGHT, 0.5, 0.0)
    n = len(x)
    ones = np.ones(n, dtype=bool)
    sim_cur = np.column_stack([2 + 3 * np.abs(x), 2.5 + 3 * np.abs(x)])
    return AuditFrame(
        run_id=run_id, group=run_id, terrain="SNOW", t_s=np.arange(n) / RATE_HZ,
        commanded_yaw_rate=x, commanded_speed=v, manoeuvre=man, quiet=~ones,
        sim_wz=x / 3.0, sim_ax=np.zeros(n), sim_ay=np.zeros(n), sim_vx=v.copy(),
        sim_cur=sim_cur, cur=sim_cur + 1.5, has_imu=True, wz=x / chi, ax=np.zeros(n),
        ay=np.zeros(n), pitch=np.zeros(n), has_pitch=ones.copy(),
        imu_t_s=np.arange(n) / RATE_HZ, imu_wz=x / chi, score_imu=ones,
        score_cur=ones.copy(), lag=LagTrack(np.empty(0), np.empty(0), np.empty(0), 0))


@pytest.mark.parametrize("online", [online_yaw_rate_samples, online_current_samples])
@pytest.mark.parametrize("name", ["lead_s", "prior_s", "memory_s"])
def test_a_nan_online_setting_is_refused_not_read_as_no_evidence(online, name):
    # NaN passed 'lead_s < 0' and 'prior_s < 0': every forecast then quietly fell back to
    # the replay (an online gain of exactly 0) instead of the setting being named
    with pytest.raises(ConfigError, match=rf"{name} must be a finite value"):
        online([_frame()], **{name: float("nan")})


def test_the_online_forecast_leaves_the_replay_with_valid_settings():
    # the counterpart of the NaN test: valid settings learn the run's own chi and offset
    f = _frame()
    wz = online_yaw_rate_samples([f], lead_s=2.0, memory_s=30.0, prior_s=2.0)
    spin = (wz.manoeuvre == "spin").to_numpy()
    assert np.abs(wz.online - wz.reference).to_numpy()[spin].max() > 0.05
    cur = online_current_samples([f], lead_s=2.0, memory_s=15.0, prior_s=0.0)
    assert (cur.online - cur.reference).max() == pytest.approx(1.5)
