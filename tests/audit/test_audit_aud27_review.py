"""Review aud27: the audit's seams with the readers, the simulator and the docs (units, sign
conventions, names): what one side produces, the other consumes alike."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from terrain.audit.core import AuditSettings, lateral_friction_sweep, prepare_frames
from terrain.sim import SimConfig, simulate


@pytest.fixture(scope="module")
def asphalt_run():
    """One 30 s simulated Husky run on ASPHALT (random scenario: turns both ways)."""
    return simulate(SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="random",
                              duration_s=30.0, seed=1))


@pytest.mark.slow
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


def _on_clock(run, origin_s):
    """The run with every stream's clock moved to start at ``origin_s`` (a recorder's epoch
    clock, as the readers keep it)."""
    streams = {k: s.assign(t_s=s.t_s + origin_s) for k, s in run.streams.items()}
    return replace(run, streams=streams)


@pytest.mark.slow
def test_the_lag_figure_plots_time_in_run_on_an_epoch_clock(asphalt_run):
    """fig_lags' x axis reads 'time in run (s)'; the lag track's window centres are times of
    the wheel clock, which a recorder's epoch clock puts at 1.7e9 s: that run was drawn at
    1.7e9 s, the same run recorded from 0 at 15 s (and several runs of other epochs spread
    along the axis). Both now read 15 s from the start of their record."""
    from terrain.audit.core import AuditResult
    from terrain.audit.figures import fig_lags

    settings = AuditSettings()
    runs = [asphalt_run, replace(_on_clock(asphalt_run, 1.7e9), run_id="sim/ASPHALT/epoch")]
    frames, skipped = prepare_frames(runs, settings)
    assert not skipped and all(f.lag.identifiable for f in frames)
    result = AuditResult(settings=settings, frames=tuple(frames), skipped={}, groups={},
                         residuals=pd.DataFrame(), lags=pd.DataFrame(), facts={},
                         timings_s={})
    fig = fig_lags(result)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time in run (s)"
    xs = [np.asarray(line.get_xdata(), float) for line in ax.lines[:2]]   # one per run
    want = frames[0].lag.centres_s - frames[0].t_s[0]
    for x in xs:
        np.testing.assert_allclose(x, want, atol=1e-6)


@pytest.mark.slow
def test_the_replay_commands_the_twist_the_simulators_kinematics_turn_back_into_its_speeds(
        asphalt_run, monkeypatch):
    """The replay feeds the simulator a body twist made from the measured side speeds; the
    simulator turns it back into wheel speeds (wheel_commands: skid_steer_inverse). Both
    sides of that seam are the one skid-steer relation of terrain.vehicles (side order left,
    right; yaw rate positive turning left): the twist is skid_steer_forward's, and the
    wheels it commands are the measured speeds, interpolated onto the physics grid at the
    end of each step (the integrator's row k is the plant at t_k since 2026-11-30, so the
    step from t_k is commanded the speed measured at t_k + dt, which the replay's motor
    reaches at the end of the step)."""
    from terrain.audit import replay as replay_module
    from terrain.sim.dynamics import integrate, wheel_commands
    from terrain.vehicles import HUSKY, skid_steer_forward

    seen = {}

    def spy(vehicle, geometry, terrains, segment_m, t, twist, *args, **kwargs):
        seen.update(vehicle=vehicle, geometry=geometry, t=t, twist=twist)
        return integrate(vehicle, geometry, terrains, segment_m, t, twist, *args, **kwargs)

    monkeypatch.setattr(replay_module, "integrate", spy)
    run = replace(asphalt_run, streams={**asphalt_run.streams, "wheels": asphalt_run.streams[
        "wheels"].assign(vel_l=lambda w: 0.3 + 0.0 * w.t_s,
                         vel_r=lambda w: 0.3 + 0.4 * np.sin(0.5 * w.t_s))})
    rep = replay_module.replay_run(run, replay_module.ReplaySettings(merge_subresolution=False))
    rel = rep.t_s - rep.t_s[0]
    dt = seen["t"][1] - seen["t"][0]
    vl = np.interp(seen["t"] + dt, rel, rep.vel_l)
    vr = np.interp(seen["t"] + dt, rel, rep.vel_r)
    v, w = skid_steer_forward(vl, vr, HUSKY.track_m)
    np.testing.assert_array_equal(seen["twist"], np.column_stack([v, np.zeros_like(v), w]))
    omega, _, clipped = wheel_commands(seen["vehicle"], seen["geometry"], seen["twist"])
    assert not clipped.any()
    r_w = seen["geometry"].wheel_radius_m
    np.testing.assert_allclose(omega * r_w, np.column_stack([vl, vr]), rtol=0, atol=1e-12)
    # the right side faster: a left turn, positive yaw rate in the replay as in the command
    turning = (rep.vel_r - rep.vel_l) > 0.2
    assert np.all(rep.yaw_rate[turning & (rel > 3)] > 0)


@pytest.mark.slow
def test_the_current_ceilings_side_speeds_are_the_measured_sides(asphalt_run):
    """The current ceiling's regressor |v_side| is rebuilt from the frame's commanded speed
    and yaw rate (skid_steer_forward of the measured sides): side 0 is the left wheel's
    record, side 1 the right's (a swapped or mis-signed inverse fed each side the other's)."""
    from terrain.audit.ceiling import _side_speed
    from terrain.audit.replay import replay_run
    from terrain.audit.frames import prepare_frame
    from terrain.vehicles import HUSKY

    rep = replay_run(asphalt_run)
    frame = prepare_frame(asphalt_run, rep)
    for side, v in enumerate((rep.vel_l, rep.vel_r)):
        np.testing.assert_allclose(_side_speed(frame, side, HUSKY.track_m), np.abs(v),
                                   rtol=0, atol=1e-12)


def test_the_coulomb_turning_form_is_the_simulators_planted_turning_current():
    """The audit's coulomb turning_resistance, ``k_a tanh(|x| / s) / tanh(turn_ref / s)``,
    is the shape the simulator plants (motor_currents: ``value tanh(|r| / s)``) with one
    scale s, the simulator's TURN_RATE_SCALE_RAD_S (read by both parameter sets, not
    written twice): on a simulated run's own yaw rate, the planted extra current is the
    audit's term with ``k_a = value tanh(turn_ref / s)`` on both sides."""
    from terrain.audit.effects import CurrentParams, EffectSettings
    from terrain.sim.effects import TURN_RATE_SCALE_RAD_S, Effects
    from terrain.sim.simulate import motor_currents, simulate_with_physics
    from terrain.vehicles import HUSKY

    assert EffectSettings().coulomb_scale_rad_s == TURN_RATE_SCALE_RAD_S
    assert CurrentParams().coulomb_scale_rad_s == TURN_RATE_SCALE_RAD_S
    assert CurrentParams().turn_ref_rad_s == EffectSettings().turn_ref_rad_s
    phys = simulate_with_physics(SimConfig(vehicle="husky", terrains=("ASPHALT",),
                                           scenario="random", duration_s=10.0,
                                           seed=2)).physics
    value = 2.5
    extra = (motor_currents(phys, HUSKY, Effects(turning_resistance=value))
             - motor_currents(phys, HUSKY, Effects()))
    params = CurrentParams(form="coulomb")
    k_a = value * np.tanh(params.turn_ref_rad_s / params.coulomb_scale_rad_s)
    term = k_a * params.turning_shape(phys.twist[:, 2])
    np.testing.assert_allclose(extra, np.column_stack([term, term]), rtol=0, atol=1e-12)


@pytest.mark.slow
def test_the_replay_and_the_frame_filter_at_the_runs_own_stream_rates(asphalt_run,
                                                                      monkeypatch):
    """The wheel input low-pass (input_cutoff_hz) and the IMU low-pass run at the streams'
    rates as the Run gives them (Run.rate_hz: the median step), the rate terrain audit's
    clipping note reads: on timestamps with jitter the two are one number."""
    from terrain.audit import frames as frames_module
    from terrain.audit import replay as replay_module

    rng = np.random.default_rng(0)
    streams = {k: s.assign(t_s=s.t_s + rng.uniform(0.0, 2e-3, len(s)))
               for k, s in asphalt_run.streams.items() if k in ("wheels", "imu")}
    run = replace(asphalt_run, streams=streams)
    rates, lowpass = [], replay_module.lowpass

    def spy(values, rate_hz, cutoff_hz, padtype="odd"):
        rates.append(float(rate_hz))
        return lowpass(values, rate_hz, cutoff_hz, padtype)

    monkeypatch.setattr(replay_module, "lowpass", spy)
    monkeypatch.setattr(frames_module, "lowpass", spy)
    rep = replay_module.replay_run(run, replay_module.ReplaySettings(input_cutoff_hz=2.0))
    assert rates[:2] == [run.rate_hz("wheels")] * 2       # vel_l, vel_r
    rates.clear()
    frames_module.prepare_frame(run, rep)
    assert rates[0] == run.rate_hz("imu")                 # wz, ax, ay


@pytest.mark.slow
def test_the_sweeps_replayed_chi_is_taken_on_the_samples_of_the_measured_chi(asphalt_run):
    """Two paths, one answer: at factor 1 the sweep replays the catalogue terrain, so its
    chi is the replay's chi on the samples the measured chi (chi_pooled) is taken on."""
    from terrain.audit.frames import CURVE, SPIN
    from terrain.vehicles.icr import icr_expansion_factor

    settings = AuditSettings()
    imu = asphalt_run.streams["imu"]
    short = replace(asphalt_run, streams={**asphalt_run.streams,
                                          "imu": imu[imu.t_s >= 10.0]})   # turns before
    frames, _ = prepare_frames([short], settings)
    f = frames[0]
    m = f.score_imu & np.isin(f.manoeuvre, (CURVE, SPIN))
    want = icr_expansion_factor(f.sim_wz[m], f.commanded_yaw_rate[m])
    got = lateral_friction_sweep([short], f.terrain, (1.0,), settings).replay_chi.iloc[0]
    assert got == pytest.approx(want, rel=1e-9)


@pytest.mark.slow
def test_the_replay_runs_the_physics_at_the_simulators_default_rate(asphalt_run, monkeypatch):
    """ReplaySettings' default physics rate is the simulator's (SimConfig's, read there, not
    written twice): the baseline is the simulator as it runs by default, and a simulated run
    is replayed on the grid it was simulated on (its meta rates_hz.physics)."""
    from terrain.audit import replay as replay_module

    assert replay_module.ReplaySettings().physics_rate_hz == SimConfig().physics_rate_hz
    assert asphalt_run.meta["rates_hz"]["physics"] == SimConfig().physics_rate_hz
    seen = {}
    integrate = replay_module.integrate

    def spy(vehicle, geometry, terrains, segment_m, t, *args, **kwargs):
        seen["t"] = t
        return integrate(vehicle, geometry, terrains, segment_m, t, *args, **kwargs)

    monkeypatch.setattr(replay_module, "integrate", spy)
    replay_module.replay_run(asphalt_run)
    np.testing.assert_allclose(np.diff(seen["t"]),
                               1.0 / asphalt_run.meta["rates_hz"]["physics"], rtol=1e-12)
