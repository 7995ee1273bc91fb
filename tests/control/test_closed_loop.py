"""Closed loop in simulation: hook, online sensors, traction loop, grid rules."""

from __future__ import annotations

import math

import numpy as np
import pytest
from control_helpers import observation

from terrain.control import build_slip_table, config_for_vehicle
from terrain.control.closed_loop import (BUS_VOLTAGE_V, FIRST_FEEDFORWARD_STEP_S, TractionLoop,
                                         fallback_basis, run_closed_loop)
from terrain.control.estimators import VelocityEstimate
from terrain.control.feedforward import traction_acceleration_limit
from terrain.control.grid import TUNING_SEEDS, run_grid, slip_limit_bound
from terrain.errors import ConfigError
from terrain.sim.closed_loop import OnlineSensors, make_hook, simulate_closed_loop
from terrain.sim.simulate import DEFAULT_SENSORS, SimConfig, simulate_with_physics
from terrain.terramechanics import get_terrain


def _config(vehicle="husky", terrain="ICE", duration=3.0, seed=4):
    return SimConfig(vehicle=vehicle, terrains=(terrain,), scenario="straight_accel",
                     duration_s=duration, seed=seed)


def test_zero_correction_hook_leaves_the_run_identical():
    cfg = _config()
    calls = []
    open_loop = simulate_with_physics(cfg)
    closed = simulate_with_physics(cfg, hook=lambda snap: calls.append(snap.t_s) or np.zeros(2))
    assert len(calls) == len(open_loop.physics.t_s)
    np.testing.assert_array_equal(open_loop.physics.twist, closed.physics.twist)
    np.testing.assert_array_equal(open_loop.physics.omega_cmd, closed.physics.omega_cmd)
    for name, frame in open_loop.run.streams.items():
        assert frame.equals(closed.run.streams[name]), name


def test_controller_sees_samples_at_sensor_rates_only():
    cfg = _config("agrimaro", "TILES", duration=2.0)
    seen = []
    sim = simulate_closed_loop(cfg, lambda obs: seen.append(obs) or np.zeros(3), 50.0)
    s = DEFAULT_SENSORS["agrimaro"]
    n_imu = sum(len(o.imu) for o in seen)
    n_cam = sum(len(o.cam) for o in seen)
    assert 100 <= len(seen) <= 101                     # 50 Hz controller over 2 s
    assert abs(n_imu - 2.0 * s.imu_rate_hz) <= 2
    # every sensor at its own rate (the camera's bound alone let a camera at half its rate,
    # or none, pass): the camera rows the outages removed are counted in the metadata
    assert abs(n_cam + sim.run.meta["controller_cam_rows_dropped"] - 2.0 * s.cam_rate_hz) <= 1
    assert n_cam > 0
    for name, rate in (("wheels", s.wheel_rate_hz), ("steer", s.steer_rate_hz),
                       ("currents", s.wheel_rate_hz)):
        assert abs(sum(len(getattr(o, name)) for o in seen) - 2.0 * rate) <= 1, name
    assert all(o.wheels.shape[1] == 4 for o in seen)    # t + three wheels
    times = np.concatenate([o.imu[:, 0] for o in seen])
    assert np.all(np.diff(times) > 0)                   # each sample delivered once, in order


class _StaleEstimator:
    name, limits = "stale", "never has a fresh estimate"

    def update(self, obs):
        n = len(obs.omega_low_level)
        return VelocityEstimate(np.zeros(n), np.full(n, 0.5), np.zeros(n), 0.5, math.inf)


def test_stale_estimate_gives_no_correction():
    cfg = _config(duration=2.0)
    ctrl_cfg, n = config_for_vehicle("husky", kp=10.0)
    loop = TractionLoop(ctrl_cfg, n, _StaleEstimator(), build_slip_table(["ICE"]),
                        lambda t: ("ICE", 1.0), apply=True)
    sim = simulate_closed_loop(cfg, loop)
    assert all(r["safe"].all() for r in loop.log)
    assert all(np.all(r["correction"] == 0.0) for r in loop.log)
    np.testing.assert_array_equal(sim.physics.omega_cmd,
                                  simulate_with_physics(cfg).physics.omega_cmd)


@pytest.mark.slow
@pytest.mark.parametrize("vehicle,estimator", [("agrimaro", None), ("husky", "observer")])
def test_traction_control_cuts_slip_on_ice_same_seed(vehicle, estimator):
    off = run_closed_loop(vehicle, "ICE", "straight_accel", False, 3, duration_s=5.0,
                          estimator=estimator)[2]
    on = run_closed_loop(vehicle, "ICE", "straight_accel", True, 3, duration_s=5.0,
                         estimator=estimator)[2]
    assert on["peak_slip"] < off["peak_slip"]
    assert on["slip_rmse"] < off["slip_rmse"]
    assert off["terrain_accuracy"] == 1.0 and on["bus_voltage_v"] == BUS_VOLTAGE_V[vehicle]
    assert on["distance_m"] > 2.0 and on["energy_j_per_m"] > 0


def test_shadow_mode_does_not_act():
    sim_off, loop, m = run_closed_loop("agrimaro", "ICE", "straight_accel", False, 3, 3.0)
    assert any(np.any(r["correction"] != 0) for r in loop.log)   # it would have acted...
    plain = simulate_with_physics(_config("agrimaro", "ICE", 3.0, 3)).physics
    np.testing.assert_array_equal(sim_off.physics.omega_cmd, plain.omega_cmd)  # ...but did not


def test_agrimaro_ekf_tracks_the_wheel_speeds_on_tiles():
    m = run_closed_loop("agrimaro", "TILES", "straight_accel", False, 5, duration_s=4.0)[2]
    assert m["speed_estimate_rmse_m_s"] < 0.05
    assert m["estimator"] == "agrimaro-ekf-vo-full-gyro"


def test_metrics_energy_from_currents_and_bus_voltage():
    sim, loop, m = run_closed_loop("husky", "TILES", "straight_accel", False, 2, 3.0)
    from terrain.sim.simulate import motor_currents
    from terrain.vehicles import get_vehicle
    cur = motor_currents(sim.physics, get_vehicle("husky"), sim.config.effects)
    dt = sim.physics.t_s[1] - sim.physics.t_s[0]
    assert m["energy_j_per_m"] * m["distance_m"] == pytest.approx(24.0 * cur.sum() * dt)
    motor = get_vehicle("husky").motor
    drive = motor.drive_power_w(cur, sim.physics.omega).sum() * dt
    assert m["drive_energy_j_per_m"] * m["distance_m"] == pytest.approx(drive)
    # the drive passes the shaft power plus losses: between the mechanical and bus figures
    assert m["mech_energy_j_per_m"] < m["drive_energy_j_per_m"] < m["energy_j_per_m"]


def test_grid_refuses_tuning_seeds():
    with pytest.raises(ConfigError, match="tuning seeds"):
        run_grid(["husky"], ["ICE"], ["straight_accel"], [TUNING_SEEDS[0]],
                 {"husky": (1.0, 0.0)}, 1.0)


def test_slip_limit_bound_snow_leaves_no_acceleration():
    snow = slip_limit_bound("SNOW", 0.334)
    assert snow["slip_limit"] == pytest.approx(0.167)
    assert abs(snow["accel_at_limit_m_s2"]) < 0.01          # the limit is the steady slip
    assert snow["min_time_to_cruise_s"] > 100.0
    tiles = slip_limit_bound("TILES", 0.1)
    assert tiles["min_time_to_cruise_s"] == pytest.approx(1.0)  # no limit on a firm surface


def test_bad_control_rate():
    sensors = OnlineSensors("husky", DEFAULT_SENSORS["husky"], 0, 1.0)
    with pytest.raises(ConfigError):
        make_hook(sensors, lambda o: None, 0.0)


def test_control_sim_command_writes_the_json_fields(tmp_path):
    import json

    from terrain.cli import main

    out, trace = tmp_path / "r.json", tmp_path / "t.csv"
    assert main(["control-sim", "--vehicle", "husky", "--terrain", "ice", "--scenario",
                 "straight_accel", "--controller", "traction", "--seed", "2",
                 "--duration-s", "3", "--terrain-source", "label", "--json", str(out),
                 "--csv", str(trace)]) == 0
    r = json.loads(out.read_text())
    for key in ("slip_rmse", "peak_slip", "time_to_speed_s", "energy_j_per_m", "distance_m",
                "mean_speed_m_s", "terrain_accuracy", "terrain_source", "estimator_limits"):
        assert key in r
    assert r["terrain_source"].startswith("label")
    # both clip counts of the wheel commands at the speed limit, per side (none here)
    assert r["speed_limit_clipped_steps"] == r["correction_clipped_steps"] == [0, 0]
    assert r["controller_cam_rows_dropped"] is None          # no camera on the Husky
    # default gains follow the estimator: the fused estimate's tuning, the observer's own
    assert (r["estimator"], r["kp"], r["ki"]) == ("husky-fused-slip-ekf", 2.0, 0.0)
    assert 0.0 < r["peak_slip"] <= 1.0 and r["distance_m"] > 1.0
    assert trace.read_text().startswith("t_s,v_true_m_s,slip_true_1")
    assert main(["control-sim", "--vehicle", "husky", "--terrain", "ice", "--scenario",
                 "straight_accel", "--controller", "traction", "--estimator", "observer",
                 "--duration-s", "1", "--terrain-source", "label", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert (r["estimator"], r["kp"], r["ki"]) == ("wheel-imu-observer", 5.0, 0.0)
    assert main(["control-sim", "--vehicle", "husky", "--terrain", "MUD", "--scenario",
                 "straight_accel", "--controller", "off", "--json", str(out)]) == 2


def test_current_channel_follows_the_snapshot():
    """The integrator's snapshot carries the wheel torque: the closed loop's current sensor
    samples it at the wheel rate, and with no correction it reads exactly what the replay of
    the same open-loop run (same seed, same sensors) reads."""
    from terrain.sim.closed_loop import replay_observations

    cfg = _config("husky", "SNOW", duration=2.0)
    seen = []
    simulate_closed_loop(cfg, lambda obs: seen.append(obs) or np.zeros(2), 50.0)
    live = np.concatenate([o.currents for o in seen])
    obs = list(replay_observations(simulate_with_physics(cfg)))
    cur = np.concatenate([o.currents for o in obs])
    rate = DEFAULT_SENSORS["husky"].wheel_rate_hz
    assert cur.shape[1] == 3 and abs(len(cur) - 2.0 * rate) <= 1
    np.testing.assert_allclose(live, cur, rtol=0, atol=1e-12)
    assert np.all(cur[len(cur) // 2:, 1:] > 1.0)          # driving through snow draws current


def test_fused_estimate_with_currents_drives_the_loop_on_ice():
    """With the motor currents in the loop the fused estimate gets its physics-slip
    pseudo-measurements (one every 0.2 s), is not stale once they arrive, and the controller
    cuts the start-up slip on ICE against the uncontrolled run of the same seed."""
    sim, loop, m = run_closed_loop("husky", "ICE", "straight_accel", True, 3, duration_s=3.0)
    assert m["estimator"] == "husky-fused-slip-ekf" and m["estimator_pseudo_measurements"] >= 10
    assert m["estimator_speed_bound_samples"] == 0      # the speed bound reported, not acting
    assert not all(r["safe"].all() for r in loop.log)
    _, _, off = run_closed_loop("husky", "ICE", "straight_accel", False, 3, duration_s=3.0)
    assert m["peak_slip"] < 0.6 * off["peak_slip"]


class _FixedEstimator:
    """Constant estimate: ground speed ``v`` m/s, wheels at ``rim`` m/s, acceleration ``a``."""

    name, limits = "fixed", "constant stub"

    def __init__(self, rim, v, a, radius):
        self.rim, self.v, self.a, self.radius = rim, v, a, radius

    def update(self, obs):
        n = len(obs.omega_low_level)
        return VelocityEstimate(np.full(n, self.rim / self.radius), np.full(n, self.v),
                                np.full(n, self.a), abs(self.v), 0.0)


def test_feed_forward_does_not_discard_the_braking_correction():
    """Braking on ICE with a locking wheel (ground 1 m/s, rim 0.6 m/s, slip -0.4 beyond the
    -0.015 target): the feedback speeds the wheel up (+0.77 rad/s with kp = 2). The
    feed-forward limit is far above the wheel (not engaged, its correction 0), so it must not
    replace the feedback; before, the "smaller |command|" rule picked its 0 every time (husky
    ICE random 20 s: 92 of 92 non-zero braking corrections discarded)."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=2.0)
    r = ctrl_cfg.wheel_radius_m
    corrections = {}
    for ff in (False, True):
        loop = TractionLoop(ctrl_cfg, n, _FixedEstimator(0.6, 1.0, -1.0, r),
                            build_slip_table(["ICE"]), lambda t: ("ICE", 1.0), feed_forward=ff)
        for k in range(3):
            c = loop(observation(0.02 * (k + 1), np.full(n, 0.6 / r)))
        assert np.all(loop.log[-1]["mode"] == -1)              # BRAKING
        corrections[ff] = c
    assert np.all(corrections[False] > 0.5)                     # 0.77 rad/s
    np.testing.assert_allclose(corrections[True], corrections[False], rtol=0, atol=1e-12)


def test_engaged_feed_forward_still_slows_a_spinning_wheel():
    """Accelerating on ICE from 0.2 m/s with the wheels commanded at 1 m/s rim: the
    feed-forward limit binds (0.2 / (1 - 0.0098) m/s rim) and slows the wheel more than the
    feedback, so it is applied."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=2.0)
    r = ctrl_cfg.wheel_radius_m
    loop = TractionLoop(ctrl_cfg, n, _FixedEstimator(1.0, 0.2, 1.0, r),
                        build_slip_table(["ICE"]), lambda t: ("ICE", 1.0))
    c = loop(observation(0.02, np.full(n, 1.0 / r)))
    assert loop.ff_engaged.all()
    limit = 0.2 / (r * (1 - build_slip_table(["ICE"]).entries["ICE"].traction))
    np.testing.assert_allclose(1.0 / r + c, limit, rtol=1e-9)


@pytest.mark.slow
def test_time_to_speed_is_timed_against_one_reference_for_on_and_off():
    """AgriMaRo on SNOW with the terrain decided TILES: the controller holds the wheels at
    TILES's 0.1 traction limit and the robot creeps. Timed against each run's own final
    speed the controlled run looked faster (off 1.40 s at 0.832 m/s final, on 0.80 s at
    0.485 m/s). Both are now timed against the command less SNOW's steady slip (0.167):
    off still 1.40 s, on never reaches it in 6 s. The EKF on the simplified IMU (``ekf-vo``)
    as when written: on the gyro view, the default since, the controlled run ends at the same
    speed (0.790 against 0.788 m/s) but grazes the reference at 4.81 s."""
    from terrain.control.desired_slip import build_slip_table as table_for

    table = table_for(["SNOW", "TILES"])
    off, on = (run_closed_loop("agrimaro", "SNOW", "straight_accel", c, 0, 6.0, table=table,
                               terrain_decision=lambda t: ("TILES", 1.0),
                               estimator="ekf-vo")[2]
               for c in (False, True))
    assert off["time_to_speed_s"] == pytest.approx(1.40, abs=0.05)
    # held at the wrong (TILES) limit the controlled run is slower than the uncontrolled
    # one: whether it reaches the reference within 6 s at all depends on the noise draws
    # (never until 2026-11-30, at 2.45 s since the steering offsets got a generator of their
    # own; 2.41 s on an earlier version), so only "later, if at all" is the property
    assert on["time_to_speed_s"] is None or on["time_to_speed_s"] > off["time_to_speed_s"]
    assert off["reference_speed_m_s"] == on["reference_speed_m_s"]
    assert off["reference_speed_m_s"] == pytest.approx(
        off["cruise_speed_m_s"] * (1 - 0.1668), abs=1e-3)


def test_steady_metrics_score_the_steady_target_and_excess_the_limit():
    """One-sided limiter: in steady mode the limit is the traction target (TILES 0.10) but
    the set point is the table's steady target (TILES 0.0). The Husky on TILES cruises at
    slip 0.000; scored against the limit its steady steps read 0.00 within 0.02 (an artefact)
    and its slip RMSE 0.100. Now: within 0.02 in every steady step, slip RMSE from the
    traction-mode steps only (0.05), and no slip beyond the enforced limit (excess 0)."""
    sim, loop, m = run_closed_loop("husky", "TILES", "straight_accel", True, 0, 6.0)
    assert m["steady_slip_within_0_02"] == 1.0                   # was 0.0
    assert m["steady_slip_error_mean"] < 0.005                   # was 0.0999
    assert m["slip_rmse"] < 0.07                                 # was 0.100
    assert m["slip_excess_rmse"] == 0.0
    # the excess counts only slip beyond the enforced limit, with the limit's sign
    from terrain.control.closed_loop import loop_metrics

    last = loop.log[-1]
    assert last["enabled"].all()
    last["desired"] = np.array([0.1, -0.1])
    k = np.searchsorted(sim.physics.t_s, last["t_s"] - 1e-9)
    sim.physics.slip_motor[k] = [0.4, -0.2]              # 0.3 and 0.1 beyond the limits
    n = sum(int(r["enabled"].sum()) for r in loop.log)
    assert loop_metrics(sim, loop, 24.0)["slip_excess_rmse"] == pytest.approx(
        math.sqrt((0.3 ** 2 + 0.1 ** 2) / n))


def test_peak_slip_above_the_enabling_speed_is_undefined_for_a_stuck_robot():
    # the Husky on the 15 deg snow slope never passes the 0.05 m/s enabling speed: its peak
    # slip "above 0.05 m/s" is undefined (None, n/a in the tables), not 0 (it read 0.000 in
    # the comparison table next to a run-wide peak of 1.0); a robot that moves gets a number
    _, _, stuck = run_closed_loop("husky", "SNOW", "slope_turn", False, 0, duration_s=3.0)
    assert stuck["peak_slip"] == pytest.approx(1.0) and stuck["peak_slip_gated"] is None
    _, _, moving = run_closed_loop("husky", "TILES", "slope_turn", False, 0, duration_s=3.0)
    assert 0 < moving["peak_slip_gated"] <= moving["peak_slip"]


def test_comparison_counts_runs_that_never_reach_cruise():
    """Three seeds: off reaches cruise at 1.0, 1.0 and 3.0 s, on at 1.1, 1.1 s and never on
    the seed whose off run was slow. The on run that never got there was dropped from the
    mean unsaid, and the two means over different seeds read as a faster start (1.67 ->
    1.10 s, "longer" -34 %). The increase is now over the seeds both runs reach (+10 %) and
    the table counts the runs that reach cruise."""
    import pandas as pd

    from terrain.control.grid import compare, markdown_table

    rows = [{"vehicle": "husky", "terrain": "GRASS", "scenario": "slope_turn", "seed": seed,
             "controller": ctrl, "peak_slip": 0.5, "energy_j_per_m": 100.0,
             "time_to_speed_s": t, "slip_rmse": 0.1, "steady_slip_within_0_02": None,
             "mean_speed_m_s": 0.1, "terrain_accuracy": 1.0}
            for seed, times in enumerate([(1.0, 1.1), (1.0, 1.1), (3.0, None)])
            for ctrl, t in zip(("off", "traction"), times)]
    table = compare(pd.DataFrame(rows))
    row = table.iloc[0]
    assert row["time_increase"] == pytest.approx(0.1)                  # was -0.34
    assert (row["time_to_speed_reached_off"], row["time_to_speed_reached_on"],
            row["runs"]) == (3, 2, 3)
    assert "2 of 3" in markdown_table(table)


def test_comparison_counts_the_seeds_of_the_steady_share():
    """Three seeds, controller on: only one has steady samples (within 0.02: 0.9), the other
    two none (None). The mean read 0.9 with nothing saying it rests on 1 run of 3; the
    comparison now counts the runs it is over and the table says so (the share unchanged)."""
    import pandas as pd

    from terrain.control.grid import compare, markdown_table

    rows = [{"vehicle": "husky", "terrain": "GRASS", "scenario": "slope_turn", "seed": seed,
             "controller": ctrl, "peak_slip": 0.5, "energy_j_per_m": 100.0,
             "time_to_speed_s": 1.0, "slip_rmse": 0.1,
             "steady_slip_within_0_02": within if ctrl == "traction" else None,
             "mean_speed_m_s": 0.1, "terrain_accuracy": 1.0}
            for seed, within in enumerate([0.9, None, None])
            for ctrl in ("off", "traction")]
    table = compare(pd.DataFrame(rows))
    row = table.iloc[0]
    assert row["steady_within_0_02_on"] == pytest.approx(0.9)
    assert (row["steady_within_0_02_runs_on"], row["runs"]) == (1, 3)
    assert "0.90 (1 of 3 runs)" in markdown_table(table)
    full = compare(pd.DataFrame([dict(r, steady_slip_within_0_02=0.9) for r in rows]))
    assert full.iloc[0]["steady_within_0_02_runs_on"] == 3
    assert "0.90 |" in markdown_table(full) and "of 3 runs" not in markdown_table(full)


def test_comparison_counts_the_seeds_of_the_energy_and_slip_rmse_means():
    """Three seeds: the controlled run of two of them does not move (energy per metre None)
    and never enables the controller (slip RMSE None). energy_on read 100 and slip_rmse_on
    0.1, means over 1 run of 3 with nothing saying so, beside a counted steady share. The
    comparison now counts the runs of each such mean as the steady share does, and the table
    says so where not all runs have one."""
    import pandas as pd

    from terrain.control.grid import compare, markdown_table

    rows = [{"vehicle": "husky", "terrain": "SNOW", "scenario": "spin", "seed": seed,
             "controller": ctrl, "peak_slip": 0.5,
             "energy_j_per_m": 100.0 if ctrl == "off" or seed == 0 else None,
             "time_to_speed_s": 1.0,
             "slip_rmse": 0.1 if ctrl == "off" or seed == 0 else None,
             "steady_slip_within_0_02": 0.9, "mean_speed_m_s": 0.1, "terrain_accuracy": 1.0}
            for seed in range(3) for ctrl in ("off", "traction")]
    table = compare(pd.DataFrame(rows))
    row = table.iloc[0]
    assert row["energy_on"] == pytest.approx(100.0) and row["slip_rmse_on"] == 0.1
    assert (row["energy_runs_off"], row["energy_runs_on"]) == (3, 1)
    assert (row["slip_rmse_runs_off"], row["slip_rmse_runs_on"], row["runs"]) == (3, 1, 3)
    md = markdown_table(table)
    assert "100 -> 100 (3 -> 1 of 3 runs)" in md
    assert "0.100 -> 0.100 (3 -> 1 of 3 runs)" in md
    full = compare(pd.DataFrame([dict(r, energy_j_per_m=100.0, slip_rmse=0.1) for r in rows]))
    assert full.iloc[0][["energy_runs_off", "energy_runs_on", "slip_rmse_runs_off",
                         "slip_rmse_runs_on"]].tolist() == [3, 3, 3, 3]
    assert "of 3 runs" not in markdown_table(full)


def test_energy_cut_is_paired_over_the_seeds_where_both_runs_have_an_energy():
    """Two seeds: off 100 and 200 J/m, on 110 J/m and none (the controlled run of seed 1
    does not move). The cut compared the mean over both off runs (150) with the one on run
    (110) and read a 27 % saving where the only pair costs 10 % more. It is now over the
    seeds where both runs have an energy, as ``time_increase`` is (-10 %); the means and
    their run counts are unchanged."""
    import pandas as pd

    from terrain.control.grid import compare

    rows = [{"vehicle": "husky", "terrain": "SNOW", "scenario": "spin", "seed": seed,
             "controller": ctrl, "peak_slip": 0.5, "energy_j_per_m": e,
             "time_to_speed_s": 1.0, "slip_rmse": 0.1, "steady_slip_within_0_02": 0.9,
             "mean_speed_m_s": 0.1, "terrain_accuracy": 1.0}
            for seed, energies in enumerate([(100.0, 110.0), (200.0, None)])
            for ctrl, e in zip(("off", "traction"), energies)]
    row = compare(pd.DataFrame(rows)).iloc[0]
    assert row["energy_cut"] == pytest.approx(-0.1)                    # was +0.267
    assert (row["energy_off"], row["energy_on"]) == (150.0, 110.0)
    assert (row["energy_runs_off"], row["energy_runs_on"]) == (2, 1)
    full = compare(pd.DataFrame([dict(r, energy_j_per_m=r["energy_j_per_m"] or 220.0)
                                 for r in rows])).iloc[0]
    assert full["energy_cut"] == pytest.approx(1.0 - full["energy_on"] / full["energy_off"])


def test_tuning_never_prefers_gains_that_never_reach_cruise(monkeypatch):
    """Without control the robot reaches cruise at 1.0 s; kp 1 gets there at 2.5 s, kp 2
    never in the 10 s run. A run that never reached cruise was charged a relative increase of
    1.0 (as if at 2.0 s), less than kp 1's 1.5, so the tuning chose the gains that never get
    there. Now it counts as reaching cruise at the end of the run at the earliest (+900 %)."""
    import terrain.control.grid as grid

    def fake_run(vehicle, terrain, scenario, on, seed, duration_s, gains=None, **kw):
        t = 1.0 if not on else {1.0: 2.5, 2.0: None}[gains[0]]
        return None, None, {"time_to_speed_s": t, "slip_rmse": 0.05,
                            "steady_slip_within_0_02": 1.0}

    monkeypatch.setattr(grid, "run_closed_loop", fake_run)
    best, table = grid.tune_gains("husky", ["ICE"], [1.0, 2.0], [0.0], duration_s=10.0,
                                  seeds=(1000,))
    assert best == (1.0, 0.0)                                   # was (2.0, 0.0)
    assert table.set_index("kp")["time_increase"].to_dict() == pytest.approx(
        {1.0: 1.5, 2.0: 9.0})


@pytest.mark.parametrize("rate_hz", [10.0, 50.0, 100.0])
def test_first_call_integrates_no_assumed_interval(rate_hz):
    """The first call has no previous one, so its PID integrates nothing: before, it
    integrated an assumed 0.02 s whatever the rate (husky, ki = 10, slip error -0.49: a first
    correction of -0.098 rad/s at 10, 50 and 100 Hz alike). Its ``dt_s`` is logged as 0; the
    second call integrates its real interval."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=0.0, ki=10.0)
    r = ctrl_cfg.wheel_radius_m
    loop = TractionLoop(ctrl_cfg, n, _FixedEstimator(1.0, 0.5, 1.0, r),
                        build_slip_table(["ICE"]), lambda t: ("ICE", 1.0), feed_forward=False)
    first = loop(observation(100.0, np.full(n, 1.0 / r)))
    second = loop(observation(100.0 + 1.0 / rate_hz, np.full(n, 1.0 / r)))
    np.testing.assert_allclose(first, 0.0, atol=1e-4)
    error = loop.log[-1]["desired"] - loop.log[-1]["slip_est"]
    np.testing.assert_allclose(second, 10.0 * error / rate_hz, rtol=1e-3)
    assert loop.log[0]["dt_s"] == 0.0
    assert loop.log[1]["dt_s"] == pytest.approx(1.0 / rate_hz)


def test_energy_per_metre_of_a_run_that_does_not_move_is_undefined():
    """The Husky spinning on SNOW barely turns and does not translate: its distance is
    round-off (6e-19 m in 4 s), and the energy per metre read 2.6e21 J/m as if measured.
    Below MIN_DISTANCE_M it is undefined (None, n/a in the tables), like a distance of 0."""
    from terrain.control.closed_loop import MIN_DISTANCE_M

    m = run_closed_loop("husky", "SNOW", "spin", True, 1, duration_s=4.0)[2]
    assert m["distance_m"] < MIN_DISTANCE_M
    assert m["energy_j_per_m"] is None and m["mech_energy_j_per_m"] is None
    assert m["drive_energy_j_per_m"] is None


@pytest.mark.parametrize("gains,match", [
    ((1.0,), r"gains must be a pair \(kp, ki\)"),
    ((1.0, 0.0, 0.1), r"gains must be a pair \(kp, ki\)"),       # (kp, ki, kd)
    ("12", r"gains must be a pair \(kp, ki\)"),
    (("a", 0.0), "kp"),
    ((2.0, None), "ki"),
])
def test_gains_that_are_not_a_pair_of_numbers_are_a_config_error(gains, match):
    """run_closed_loop's docstring promises a ConfigError for bad gains; (1.0,) and a
    (kp, ki, kd) triple raised Python's 'not enough / too many values to unpack' and
    ("a", 0.0) float()'s 'could not convert string to float'. Now a ConfigError naming
    what is wrong, before any simulation."""
    with pytest.raises(ConfigError, match=match):
        run_closed_loop("husky", "ICE", "straight_accel", True, 1, 1.0, gains=gains)


@pytest.mark.parametrize("tau", [-0.3, float("nan"), float("inf"), "0.3"])
def test_an_acceleration_filter_time_constant_that_is_not_finite_and_non_negative_is_refused(
        tau):
    """TractionLoop documents accel_tau_s >= 0 (0 = off), but -0.3 and NaN turned the
    filter off without a word (Power_state then follows the acceleration the correction
    causes: the limit cycle the filter is there against), inf froze the filtered
    acceleration at its first value, and the text '0.3' passed through float(). Now a
    ConfigError naming accel_tau_s when the loop is built."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=2.0)
    with pytest.raises(ConfigError, match="accel_tau_s"):
        TractionLoop(ctrl_cfg, n, _FixedEstimator(0.6, 1.0, -1.0, ctrl_cfg.wheel_radius_m),
                     build_slip_table(["ICE"]), lambda t: ("ICE", 1.0), accel_tau_s=tau)


def test_control_sim_prints_a_run_that_does_not_move(tmp_path, capsys):
    """The Husky held on the 15 deg SNOW slope for 0.2 s travels under MIN_DISTANCE_M, so its
    energy per metre is None; control-sim's summary line formatted it with ``:.1f`` and
    ended in "internal error: TypeError: unsupported format string passed to
    NoneType.__format__" after writing the JSON. It now prints n/a."""
    import json

    from terrain.cli import main

    out = tmp_path / "r.json"
    assert main(["control-sim", "--vehicle", "husky", "--terrain", "SNOW", "--scenario",
                 "slope_turn", "--controller", "off", "--duration-s", "0.2",
                 "--terrain-source", "label", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["energy_j_per_m"] is None
    assert "energy n/a" in capsys.readouterr().out


def test_engaged_feed_forward_gives_way_to_a_feedback_that_slows_the_wheel_more():
    """ICE, wheel commanded above the feed-forward limit (0.3 m/s rim against
    0.2 / (1 - 0.0098)) but measured spinning (rim 1.0 m/s over 0.2 m/s ground: slip 0.8):
    the limit binds with a correction of about -0.6 rad/s (r 0.165 m), the feedback asks
    kp (0.0098 - 0.8) = -1.58 rad/s (within the -1.8 rad/s that would stop the wheel). The
    one that slows the wheel more, the feedback's, is applied (class docstring), not the
    engaged feed-forward's."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=2.0)
    r = ctrl_cfg.wheel_radius_m
    table = build_slip_table(["ICE"])
    corrections = {}
    for ff in (False, True):
        loop = TractionLoop(ctrl_cfg, n, _FixedEstimator(1.0, 0.2, 1.0, r), table,
                            lambda t: ("ICE", 1.0), feed_forward=ff)
        corrections[ff] = loop(observation(0.02, np.full(n, 0.3 / r)))
    assert loop.ff_engaged.all()
    expected = 2.0 * (table.entries["ICE"].traction - 0.8)
    np.testing.assert_allclose(corrections[False], expected, rtol=1e-9)
    np.testing.assert_allclose(corrections[True], corrections[False], rtol=0, atol=1e-12)


def test_feed_forward_limits_on_the_fallbacks_terrain_while_no_terrain_is_decided():
    """No decision yet (label None): the fallback's targets apply, and the feed-forward
    limit is computed on the terrain the fallback's traction target comes from (ICE, the
    smallest traction target of ICE and GRASS), not switched off."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=2.0)
    r = ctrl_cfg.wheel_radius_m
    table = build_slip_table(["GRASS", "ICE"])
    assert fallback_basis(table) == "ICE"
    assert table.fallback.traction == table.entries["ICE"].traction
    loop = TractionLoop(ctrl_cfg, n, _FixedEstimator(1.0, 0.2, 1.0, r), table,
                        lambda t: (None, 0.0))
    c = loop(observation(0.02, np.full(n, 1.0 / r)))
    assert loop.ff_engaged.all()
    np.testing.assert_allclose(1.0 / r + c, 0.2 / (r * (1 - table.fallback.traction)),
                               rtol=1e-9)


def test_decision_age_is_the_time_since_the_decision_and_the_first_ramp_step_is_assumed():
    """A decision made 1 s before the call (``t_decided = t - 1``) has age +1 s: trusted
    (GRASS's targets; the table's limit is 4 s); made 10 s before: the fallback. The
    feed-forward reference of the first call, from a standing estimate, is
    ``a_max FIRST_FEEDFORWARD_STEP_S`` (module constant, 0.02 s)."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=2.0)
    r = ctrl_cfg.wheel_radius_m
    table = build_slip_table(["GRASS", "ICE"])
    for made_before, expect in ((1.0, table.entries["GRASS"]), (10.0, table.fallback)):
        loop = TractionLoop(ctrl_cfg, n, _FixedEstimator(0.0, 0.0, 0.0, r), table,
                            lambda t: ("GRASS", 0.9, t - made_before))
        loop(observation(20.0, np.full(n, 1.0 / r)))
        assert loop.log[-1]["decision_age_s"] == pytest.approx(made_before)
        assert loop.log[-1]["target_traction"] == expect.traction
    a_max = traction_acceleration_limit(get_terrain("ICE"), table.fallback.traction)
    assert a_max > 0
    np.testing.assert_allclose(loop.v_ref, a_max * FIRST_FEEDFORWARD_STEP_S, rtol=1e-12)


def test_a_non_finite_acceleration_estimate_suspends_the_control_for_that_call_only():
    """A NaN acceleration from the estimator gives the safe output for that call; the
    low-pass of the accelerations restarts from the next finite one instead of carrying the
    NaN (which would have kept every later call safe, the controller off for good)."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=2.0)
    r = ctrl_cfg.wheel_radius_m
    est = _FixedEstimator(0.6, 1.0, math.nan, r)
    loop = TractionLoop(ctrl_cfg, n, est, build_slip_table(["ICE"]), lambda t: ("ICE", 1.0))
    loop(observation(0.02, np.full(n, 0.6 / r)))
    assert loop.log[-1]["safe"].all()
    est.a = -1.0                                               # braking, locking wheel
    for k in range(2):
        c = loop(observation(0.04 + 0.02 * k, np.full(n, 0.6 / r)))
        assert not loop.log[-1]["safe"].any() and np.all(loop.log[-1]["mode"] == -1)
    assert np.all(c > 0.5)


def test_loop_metrics_summaries_from_known_values():
    """The run's summaries recomputed from the physics and the log after planting known
    values: braking (negative) shaft power is not mechanical energy spent; the cruise speed
    is the largest *mean* command of the wheels times the radius (not the fastest single
    wheel); the skid-steer sides' true speeds are ``vx -/+ yaw_rate B / 2`` (left first);
    the final speed the mean over the last ``final_window_s``."""
    from terrain.control.closed_loop import loop_metrics
    from terrain.sim.sensors import physics_step_index
    from terrain.vehicles import get_vehicle

    sim, loop, _ = run_closed_loop("husky", "TILES", "straight_accel", False, 2, 3.0)
    phys, veh = sim.physics, get_vehicle("husky")
    dt = phys.t_s[1] - phys.t_s[0]
    phys.torque[: len(phys.t_s) // 3] *= -1.0                 # a braking third
    phys.twist[:, 2] = 0.3                                    # turning at 0.3 rad/s
    big = 4.0 * max(np.abs(r["omega_low_level"]).mean() for r in loop.log)
    loop.log[5]["omega_low_level"] = np.array([big, -0.25 * big])
    m = loop_metrics(sim, loop, 24.0)
    speed = np.hypot(phys.twist[:, 0], phys.twist[:, 1])
    distance = speed.sum() * dt
    power = phys.torque * phys.omega
    assert (power < 0).any()
    assert m["mech_energy_j_per_m"] == pytest.approx(np.clip(power, 0, None).sum() * dt
                                                     / distance, rel=1e-9)
    assert m["cruise_speed_m_s"] == pytest.approx(0.625 * big * veh.wheel_radius_m, rel=1e-12)
    t_log = np.array([r["t_s"] for r in loop.log])
    idx = physics_step_index(phys.t_s, t_log)
    half = 0.5 * veh.track_m * 0.3
    v_true = np.column_stack([phys.twist[idx, 0] - half, phys.twist[idx, 0] + half])
    v_est = np.array([r["v_long"] for r in loop.log])
    assert m["speed_estimate_rmse_m_s"] == pytest.approx(
        math.sqrt(np.mean((v_est - v_true) ** 2)), rel=1e-9)
    final = speed[phys.t_s >= phys.t_s[-1] - 2.0]
    assert len(final) > 1 and m["final_speed_m_s"] == pytest.approx(final.mean(), rel=1e-12)


def test_the_logged_steady_target_takes_the_sign_of_the_motion():
    """Reversing (negative ground speed) the steady set point scored by the metrics is the
    table's steady slip with the sign of the motion (SNOW: -0.167), as forwards +0.167."""
    ctrl_cfg, n = config_for_vehicle("husky", kp=2.0)
    r = ctrl_cfg.wheel_radius_m
    table = build_slip_table(["SNOW"])
    steady = table.entries["SNOW"].steady
    assert steady > 0.1
    for sign in (1.0, -1.0):
        loop = TractionLoop(ctrl_cfg, n, _FixedEstimator(sign * 1.0, sign * 0.8, 0.0, r),
                            table, lambda t: ("SNOW", 1.0))
        loop(observation(0.02, np.full(n, sign * 1.0 / r)))
        np.testing.assert_allclose(loop.log[-1]["steady_target"], sign * steady)


def test_tuning_cost_clips_a_faster_start_and_charges_a_run_without_steady_samples(
        monkeypatch):
    """Per run: a controlled start faster than the uncontrolled one is no time increase (0,
    not a negative credit that buys a poor slip RMSE), and a run without steady samples
    counts as missing the steady target in full (1)."""
    import terrain.control.grid as grid

    def fake_run(vehicle, terrain, scenario, on, seed, duration_s, gains=None, **kw):
        if not on:
            return None, None, {"time_to_speed_s": 2.0, "slip_rmse": 0.3,
                                "steady_slip_within_0_02": 0.5}
        return None, None, {"time_to_speed_s": 1.0, "slip_rmse": 0.05,
                            "steady_slip_within_0_02": None if gains[0] == 1.0 else 0.75}

    monkeypatch.setattr(grid, "run_closed_loop", fake_run)
    best, table = grid.tune_gains("husky", ["ICE"], [1.0, 2.0], [0.0], duration_s=10.0,
                                  seeds=(1000,))
    rows = table.set_index("kp")
    assert rows["time_increase"].tolist() == [0.0, 0.0]                   # not -0.5
    assert rows["steady_miss"].to_dict() == pytest.approx({1.0: 1.0, 2.0: 0.25})
    assert best == (2.0, 0.0)
    assert rows.loc[1.0, "cost"] == pytest.approx(0.05 + 0.5 * 1.0)


def test_grid_axes_compare_terrain_names_in_any_case_and_name_the_axis():
    from terrain.control.grid import check_grid_axes

    with pytest.raises(ConfigError, match=r"terrains: .*ICE.* given more than once"):
        check_grid_axes(["husky"], ["ICE", "ice"], ["straight_accel"], [0])
    with pytest.raises(ConfigError, match=r"vehicles: .*husky"):
        run_grid(["husky", "Husky"], ["ICE"], ["straight_accel"], [0], {"husky": (2.0, 0.0)})
    check_grid_axes(["husky", "agrimaro"], ["ICE", "SNOW"], ["straight_accel"], [0, 1])


def test_grid_rows_say_where_the_terrain_decision_came_from(monkeypatch):
    """A run with a live classifier is marked ``classifier``, one on its label ``label``."""
    import terrain.control.grid as grid

    monkeypatch.setattr(grid, "run_closed_loop",
                        lambda *a, **kw: (None, None, {"peak_slip": 0.1}))
    monkeypatch.setattr("terrain.control.closed_loop.trace_frame", lambda sim, loop: None)
    live = object()
    results, _ = grid.run_grid(["husky", "agrimaro"], ["ICE"], ["straight_accel"], [0],
                               {"husky": (2.0, 0.0), "agrimaro": (5.0, 0.0)},
                               decisions={"husky": lambda ter: (live, None, "live")})
    assert results.groupby("vehicle")["terrain_source"].agg(set).to_dict() == {
        "husky": {"classifier"}, "agrimaro": {"label"}}


def test_slip_limit_bound_keeps_the_uncut_share_of_the_peak():
    """A cut of 0.75 of a 0.4 peak leaves a limit of 0.1 (the default cut 0.5 cannot tell
    the share kept from the share removed)."""
    b = slip_limit_bound("GRASS", 0.4, cut=0.75)
    assert b["slip_limit"] == pytest.approx(0.1)
    assert b["accel_at_limit_m_s2"] == pytest.approx(
        traction_acceleration_limit(get_terrain("GRASS"), 0.1))


def test_steady_slip_error_counts_only_after_cruise_plus_the_settling_time():
    """Steady steps count from ``time_to_speed_s + steady_after_s`` on, not from
    ``steady_after_s`` after the start: a large error planted in between is not scored."""
    from terrain.control.closed_loop import loop_metrics

    sim, loop, m = run_closed_loop("husky", "TILES", "straight_accel", True, 0, 6.0)
    t_speed = m["time_to_speed_s"]
    assert t_speed is not None and t_speed > 0.5 and m["steady_slip_error_max"] < 0.02
    from terrain.sim.sensors import physics_step_index

    t_log = np.array([r["t_s"] for r in loop.log])
    early = (t_log >= 3.0) & (t_log < t_speed + 3.0)
    assert early.any()
    sim.physics.slip_motor[physics_step_index(sim.physics.t_s, t_log[early])] = 0.9
    assert loop_metrics(sim, loop, 24.0)["steady_slip_error_max"] < 0.02


def test_an_undecided_terrain_gives_the_fused_estimator_the_fallback_terrain():
    """With no terrain decided the fused estimator's slip model assumes the fallback's
    terrain, so its pseudo-measurements keep coming (without, the slip common to both sides
    is unobservable and the estimate reported stale)."""
    m = run_closed_loop("husky", "ICE", "straight_accel", True, 0, 2.0,
                        terrain_decision=lambda t: (None, 0.0))[2]
    assert m["estimator_pseudo_measurements"] > 0


def test_bus_voltages_are_the_cited_ones():
    # AgriMaRo: seed 001 ch. 3, the UuMotor hub motor "powered at 48V"; Husky A200: 24 V
    # (Clearpath data sheet); docs/control_validation.md's energy_j_per_m uses them
    # (hand mutant: AgriMaRo 24 V, no test failed: the tests compared with the constant)
    assert dict(BUS_VOLTAGE_V) == {"agrimaro": 48.0, "husky": 24.0}


def test_default_gains_are_the_tuned_ones_the_docs_state():
    # docs/control_validation.md, "Gain tuning" (re-tuned 2026-11-26): DEFAULT_GAINS AgriMaRo
    # (5, 0), Husky with the fused estimate (2, 0), ESTIMATOR_GAINS observer (5, 0); every
    # control figure there was measured with them (hand mutant: AgriMaRo ki 10, no test failed)
    from terrain.control.closed_loop import default_gains
    assert default_gains("agrimaro") == (5.0, 0.0)
    assert default_gains("husky") == default_gains("husky", "fused") == (2.0, 0.0)
    assert default_gains("husky", "observer") == (5.0, 0.0)
