"""Helpers of the audit tests: simulated and real runs written as signal files only.

Every audit in these tests reads a folder in the measured-run layout that holds nothing but
``imu_XX.csv`` and ``pro_XX.csv`` (no ground truth, no metadata). Effects are planted either
by the simulator (``terrain.sim`` effects) or by the helpers below, which modify the signal
files the way the effect would.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy import ndimage

from terrain.audit import AuditSettings, SelectionSettings, run_audit
from terrain.io.measured import read_runs_dir
from terrain.run import Run
from terrain.io.writer import to_file_frames
from terrain.sim import SimConfig, parse_effects, simulate
from terrain.vehicles import HUSKY
from terrain.vehicles.icr import icr_expansion_factor

G = 9.80665
B = HUSKY.track_m
#: fast but still meaningful selection settings for tests
FAST = AuditSettings(selection=SelectionSettings(n_bootstrap=300, n_param_bootstrap=30),
                     pooled=False)
#: seeds of the simulated runs (three runs per case, 60 s each)
SIM_SEEDS = (31, 32, 33)
SIM_DURATION_S = 60.0
IMU_COLUMNS = ["time", "wx", "wy", "wz", "ax", "ay", "az"]
PRO_COLUMNS = ["time", "curL", "curR", "velL", "velR"]


def write_signal_files(root: Path, terrain: str, index: int, imu: pd.DataFrame | None,
                       pro: pd.DataFrame) -> None:
    """Write ``<root>/<terrain>/{imu,pro}_<index>.csv`` (file column names)."""
    folder = Path(root) / terrain
    folder.mkdir(parents=True, exist_ok=True)
    if imu is not None:
        imu[IMU_COLUMNS].to_csv(folder / f"imu_{index:02d}.csv", index=False,
                                float_format="%.9g")
    pro[PRO_COLUMNS].to_csv(folder / f"pro_{index:02d}.csv", index=False, float_format="%.9g")


def simulated_streams(effects: dict | None = None, seeds=SIM_SEEDS, terrain: str = "ASPHALT",
                      scenario: str = "random", duration_s: float = SIM_DURATION_S,
                      physics: str = "v1"):
    """(imu, pro) file frames of simulated Husky runs with the given planted effects."""
    out = []
    for seed in seeds:
        res = to_file_frames(simulate(SimConfig(
            vehicle="husky", terrains=(terrain,), scenario=scenario, duration_s=duration_s,
            seed=seed, effects=parse_effects(effects or {}), physics=physics)))
        out.append((res["imu"].copy(), res["pro"].copy()))
    return out


def simulated_truth_chi(effects: dict | None = None, seeds=SIM_SEEDS,
                        terrain: str = "ASPHALT", scenario: str = "random",
                        duration_s: float = SIM_DURATION_S, physics: str = "v1",
                        min_yaw_rate_rad_s: float = 0.1) -> float:
    """ICR expansion chi of the same simulated runs as :func:`simulated_streams`, from their
    ground truth: least squares of the true yaw rate on the true wheels' ``(v_R - v_L) / B``
    over the samples turning faster than ``min_yaw_rate_rad_s`` (rad/s)."""
    ys, xs = [], []
    for seed in seeds:
        truth = simulate(SimConfig(
            vehicle="husky", terrains=(terrain,), scenario=scenario, duration_s=duration_s,
            seed=seed, effects=parse_effects(effects or {}), physics=physics)).streams["truth"]
        x = (truth.omega_2 - truth.omega_1).to_numpy() * HUSKY.wheel_radius_m / B
        turning = np.abs(x) > min_yaw_rate_rad_s
        ys.append(truth.yaw_rate.to_numpy()[turning])
        xs.append(x[turning])
    return icr_expansion_factor(np.concatenate(ys), np.concatenate(xs))


def run_to_files(run: Run) -> tuple[pd.DataFrame | None, pd.DataFrame]:
    """A shipped run's streams as file frames (``time`` and the files' column names)."""
    pro = run.streams["wheels"].rename(columns={"t_s": "time", "vel_l": "velL",
                                                "vel_r": "velR", "cur_l": "curL",
                                                "cur_r": "curR"})
    imu = run.streams.get("imu")
    if imu is not None:
        imu = imu.rename(columns={"t_s": "time"})
    return imu, pro


def turning_episodes(pro: pd.DataFrame, threshold_rad_s: float = 0.1):
    """``(t_start, t_end)`` of each stretch where ``|v_R - v_L| / B >= threshold``."""
    x = ((pro.velR - pro.velL) / B).to_numpy()
    t = pro.time.to_numpy()
    lab, n = ndimage.label(np.abs(x) >= threshold_rad_s)
    return [(t[np.flatnonzero(lab == k)[0]], t[np.flatnonzero(lab == k)[-1]])
            for k in range(1, n + 1)]


def plant_immobilised(imu: pd.DataFrame, pro: pd.DataFrame, fraction: float,
                      rng: np.random.Generator) -> pd.DataFrame:
    """The robot digs in for ``fraction`` of every turn (a contiguous stretch at a random
    place): the gyro shows no yaw there (its noise stays), the wheels keep turning."""
    imu = imu.copy()
    ti = imu.time.to_numpy()
    wz = imu.wz.to_numpy().copy()
    trend = imu.wz.rolling(25, center=True, min_periods=1).mean().to_numpy()
    for t0, t1 in turning_episodes(pro):
        length = t1 - t0
        start = t0 + rng.uniform(0.0, 1.0) * (1.0 - fraction) * length
        m = (ti >= start) & (ti <= start + fraction * length)
        wz[m] = wz[m] - trend[m]
    imu["wz"] = wz
    return imu


def plant_grade(imu: pd.DataFrame, pro: pd.DataFrame, k_a_per_rad: float,
                rng: np.random.Generator, amplitude_rad: float = 0.15,
                period_s: float = 20.0) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Drive over rolling hills: pitch ``amplitude sin(2 pi t / period + phase)`` seen by the
    accelerometer (``g sin(pitch)`` on x) and ``k_a_per_rad |pitch|`` on both currents."""
    phase = rng.uniform(0.0, 2.0 * np.pi)

    def pitch(t):
        return amplitude_rad * np.sin(2.0 * np.pi * np.asarray(t) / period_s + phase)
    imu = imu.copy()
    pro = pro.copy()
    imu["ax"] = imu.ax + G * np.sin(pitch(imu.time))
    extra = k_a_per_rad * np.abs(pitch(pro.time))
    pro["curL"] = pro.curL + extra
    pro["curR"] = pro.curR + extra
    return imu, pro


def audit_folder(root: Path, settings: AuditSettings = FAST):
    """Read a measured-run folder and audit it."""
    return run_audit(read_runs_dir(root), settings)


def synthetic_frame(run_id: str, terrain: str = "ASPHALT", bias_rad_s: float = 0.0,
                    chi: float | None = None, offsets_a: tuple[float, float] = (0.0, 0.0),
                    noise: float = 0.005, seed: int = 0, n_cycles: int = 4,
                    drift_rad_s: float = 0.0):
    """An :class:`~terrain.audit.frames.AuditFrame` built directly (no replay, no IMU file):
    cycles of 10 s straight at 0.5 m/s, a 5 s curve (``x = 0.5`` rad/s), 10 s straight and a
    5 s spin in place (``x = -0.8``), at 10 Hz. The replay's yaw rate is ``x / 1.2`` and its
    currents ``2 + |x|`` A; the gyro reads the replay (or ``x / chi``) plus ``bias_rad_s`` and
    white noise of ``noise`` rad/s, the currents the replay's plus ``offsets_a`` (left, right)
    while moving and noise of ``10 noise`` A. ``drift_rad_s`` is the commanded yaw rate of
    the straight stretches (below the turn threshold). No lag (an empty, unidentifiable
    track)."""
    from terrain.audit.frames import AuditFrame, FrameSettings, _quiet, classify_manoeuvres
    from terrain.audit.timing import LagTrack

    rng = np.random.default_rng(seed)
    dt = 0.1
    straight = np.full(100, drift_rad_s)
    cycle = np.r_[straight, np.full(50, 0.5), straight, np.full(50, -0.8)]
    speed = np.r_[np.full(100, 0.5), np.full(50, 0.5), np.full(100, 0.5), np.zeros(50)]
    x = np.tile(cycle, n_cycles)
    v = np.tile(speed, n_cycles)
    n = x.size
    t = np.arange(n) * dt
    vel_l, vel_r = v - 0.5 * x * B, v + 0.5 * x * B
    man = classify_manoeuvres(x, v, vel_l, vel_r, B)
    moving = man != 0
    sim_wz = x / 1.2
    wz = (sim_wz if chi is None else x / chi) + bias_rad_s + noise * rng.standard_normal(n)
    sim_cur = np.column_stack([2.0 + np.abs(x)] * 2)
    cur = (sim_cur + np.outer(moving, offsets_a)
           + 10 * noise * rng.standard_normal((n, 2)))
    score = (t >= t[0] + 2.0) & (t <= t[-1] - 2.0)
    return AuditFrame(
        run_id=run_id, group=run_id, terrain=terrain, t_s=t, commanded_yaw_rate=x,
        commanded_speed=v, manoeuvre=man, quiet=_quiet(t, x, FrameSettings()),
        sim_wz=sim_wz, sim_ax=np.zeros(n), sim_ay=np.zeros(n), sim_vx=v, sim_cur=sim_cur,
        cur=cur, has_imu=True, wz=wz, ax=np.zeros(n), ay=np.zeros(n), pitch=np.zeros(n),
        has_pitch=np.ones(n, dtype=bool), imu_t_s=t, imu_wz=wz, score_imu=score,
        score_cur=score.copy(), lag=LagTrack(np.empty(0), np.empty(0), np.empty(0), 0))
