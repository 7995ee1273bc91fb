"""Review simrev of the integrator's implicit step and the simulation entry point
(terrain/sim/dynamics.py ``implicit_euler_step`` and ``integrate``, terrain/sim/simulate.py).

Physical and numerical invariants of short runs: every converged step solves the implicit
equation within its tolerance, the run's counts are the sums of its steps', a mirrored spin
(where the Newton iterations run on central differences) is the mirrored run, and
non-finite forces or a hook's unreadable correction are refused with the step named.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import terrain.sim.dynamics as dynamics
from terrain.errors import ConfigError, NonFiniteInputError, TerrainError
from terrain.sim import SimConfig, simulate
from terrain.sim.dynamics import IMPLICIT_TOLERANCE_PER_S3, implicit_euler_step, integrate
from terrain.sim.forces import (ContactForces, contact_layout, contact_torque_nm,
                                step_traction_coefficient, velocity_maps)
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

M = np.diag([50.0, 50.0, 2.0])
M_INV = np.linalg.inv(M)


def _contact(force, jacobian=np.zeros((3, 3))):
    return ContactForces(np.asarray(force, float), np.asarray(jacobian, float), np.zeros(4),
                         np.zeros(4), np.zeros(4))


def _commands(t, kind, level):
    """A ramp to ``level`` m/s (``ramp``) or a spin to ``level`` rad/s (``spin``)."""
    tw = np.zeros((len(t), 3))
    tw[:, 0 if kind == "ramp" else 2] = np.minimum(t + 0.01, level)
    return tw


def _recorded_run(monkeypatch, vehicle, terrain, physics, kind, level, duration=2.0):
    """A run with every implicit step recorded: (dt, result, the contact forces at the
    step's end, its velocity error recomputed there, the traction coefficients the motors
    were charged) (``contact_at`` is evaluated in the step: it reads the step's wheel
    speeds and loads when called)."""
    steps = []

    def recording(m_mat, m_inv, dt, vel, first, force, contact_at, where=""):
        out = implicit_euler_step(m_mat, m_inv, dt, vel, first, force, contact_at, where)
        dv = out[0]
        end = contact_at(vel + dv)
        residual = dt * (end.force + force - first.force) - m_mat @ dv
        steps.append([dt, vel, out, end, float(np.abs(m_inv @ residual).max())])
        return out

    def charging(layout, terrain, mu, *args, **kwargs):
        steps[-1].append(np.array(mu))
        return contact_torque_nm(layout, terrain, mu, *args, **kwargs)

    monkeypatch.setattr(dynamics, "implicit_euler_step", recording)
    monkeypatch.setattr(dynamics, "contact_torque_nm", charging)
    veh = get_vehicle(vehicle)
    t = np.arange(0.0, duration, 0.01)
    run = integrate(veh, veh.contact_geometry(), (get_terrain(terrain),), np.inf, t,
                    _commands(t, kind, level), 0.0, 1.0, physics=physics)
    return veh, run, steps


# the cases where the Newton iterations run (friction limit of ice, peaked curves in a spin,
# the tyre law's kinks, soils), some of them into the central-difference Jacobian
CASES = [("husky", "ICE", "v1", "ramp", 0.5), ("husky", "PACKED_SNOW", "v1", "spin", 0.4),
         ("husky", "SNOW", "v2", "spin", 0.4), ("tracked", "SNOW", "v2", "spin", 0.4),
         ("husky", "SANDY_LOAM", "v2", "ramp", 0.8), ("husky", "ASPHALT", "v2", "spin", 0.4)]


@pytest.mark.parametrize("vehicle, terrain, physics, kind, level", CASES)
def test_every_converged_step_solves_the_implicit_equation_and_the_counts_add_up(
        monkeypatch, vehicle, terrain, physics, kind, level):
    # M dv = dt (F(V + dv) + G) within IMPLICIT_TOLERANCE_PER_S3 dt^2 of velocity error,
    # recomputed from the step's own force law; the run's counts are the steps' sums
    _, run, steps = _recorded_run(monkeypatch, vehicle, terrain, physics, kind, level)
    assert len(steps) == len(run.t_s) - 1
    for k, (dt, vel, (dv, _, _, _, ok, _, _), _, error, _) in enumerate(steps):
        assert ok and error <= IMPLICIT_TOLERANCE_PER_S3 * dt * dt, k
        np.testing.assert_array_equal(run.twist[k + 1], vel + dv)
    assert run.implicit_iterations == sum(s[2][3] for s in steps) > 0
    assert run.implicit_unconverged_steps == sum(not s[2][4] for s in steps) == 0


@pytest.mark.parametrize("vehicle, terrain, physics", [
    ("husky", "PACKED_SNOW", "v1"), ("husky", "SNOW", "v2"), ("tracked", "PACKED_SNOW", "v1"),
    ("husky", "SANDY_LOAM", "v2")])
def test_a_mirrored_spin_is_the_mirrored_run_with_the_same_iterations(vehicle, terrain,
                                                                      physics):
    # a spin in place past a peaked traction curve: Newton iterations on central differences
    # (the Husky on PACKED_SNOW, v1); left and right spins must stay mirrors, the left and
    # right motors swapped, and a symmetric vehicle spinning in place stays where it is
    veh = get_vehicle(vehicle)
    t = np.arange(0.0, 2.0, 0.01)
    cmd = _commands(t, "spin", 0.4)
    left, right = (integrate(veh, veh.contact_geometry(), (get_terrain(terrain),), np.inf, t,
                             c, 0.0, 1.0, physics=physics) for c in (cmd, -cmd))
    assert left.pose[-1, 2] > 0.05 and left.implicit_iterations > 0
    assert right.implicit_iterations == left.implicit_iterations
    assert right.implicit_unconverged_steps == left.implicit_unconverged_steps == 0
    # (central differences of step 1e-6 m/s carry the rounding of the sums over contacts)
    np.testing.assert_allclose(right.pose, left.pose * [1.0, -1.0, -1.0], atol=1e-7)
    np.testing.assert_allclose(right.twist, left.twist * [1.0, -1.0, -1.0], atol=1e-7)
    np.testing.assert_allclose(right.torque, left.torque[:, ::-1], atol=1e-5)
    np.testing.assert_allclose(right.slip_motor, left.slip_motor[:, ::-1], atol=1e-6)
    assert np.abs(left.pose[:, :2]).max() < 1e-7


@settings(max_examples=15, deadline=None)
@given(vehicle=st.sampled_from(["husky", "tracked"]),
       terrain=st.sampled_from(["ICE", "PACKED_SNOW", "SNOW", "SANDY_LOAM", "ASPHALT"]),
       physics=st.sampled_from(["v1", "v2"]))
def test_a_vehicle_at_rest_without_a_command_takes_no_newton_iteration(vehicle, terrain,
                                                                       physics):
    # at rest on level ground with zero commands the forces are zero and linear: the
    # linearly implicit step is the solution, no iteration runs and nothing moves
    veh = get_vehicle(vehicle)
    t = np.arange(0.0, 0.5, 0.01)
    run = integrate(veh, veh.contact_geometry(), (get_terrain(terrain),), np.inf, t,
                    np.zeros((len(t), 3)), 0.0, 1.0, physics=physics)
    assert run.implicit_iterations == run.implicit_unconverged_steps == 0
    assert not run.pose.any() and not run.twist.any() and not run.torque.any()


def test_the_newton_loop_keeps_its_best_finite_iterate_and_its_linearisation():
    # a force law whose Newton steps never converge (a discontinuity with no root between):
    # the step stops at the limit, keeps the iterate of the smallest error, and the pair
    # (linearised, last_step), its exactness and its end forces it returns are that
    # iterate's (linearised: the forces at the iterate before it, dv - last_step), as the
    # motor torque reads them
    dt = 0.01

    def at(twist):
        return _contact([-300.0 * np.sign(twist[0] - 0.19) - 10.0 * twist[0], 0.0, 0.0],
                        np.diag([-10.0, 0.0, 0.0]))

    vel = np.array([0.2, 0.0, 0.0])
    first = at(vel)
    dv, lin, last, its, ok, exact, end = implicit_euler_step(M, M_INV, dt, vel, first,
                                                             first.force, at)
    assert not ok and its == dynamics.IMPLICIT_MAX_ITERATIONS
    assert np.all(np.isfinite(dv))
    error = np.abs(M_INV @ (dt * at(vel + dv).force - M @ dv)).max()
    # no iterate it visited is better: at least the first, linearly implicit, one
    lin_dv = np.linalg.solve(M - dt * first.jacobian, dt * first.force)
    assert error <= np.abs(M_INV @ (dt * at(vel + lin_dv).force - M @ lin_dv)).max()
    np.testing.assert_array_equal(lin.force, at(vel + dv - last).force)
    np.testing.assert_array_equal(end.force, at(vel + dv).force)


def test_a_nan_force_met_by_a_newton_step_is_backtracked_from():
    # a force law that is NaN beyond v = 0.3 m/s: a full step into it is halved back
    dt = 0.01

    def at(twist):
        v = twist[0]
        f = -400.0 * np.tanh(v / 0.02) if v < 0.3 else np.nan
        return _contact([f, 0.0, 0.0], np.diag([-20.0, 0.0, 0.0]))

    vel = np.array([0.25, 0.0, 0.0])
    first = at(vel)
    dv, _, _, _, ok, _, _ = implicit_euler_step(M, M_INV, dt, vel, first, first.force, at)
    assert ok and np.all(np.isfinite(dv))


@pytest.mark.parametrize("vehicle, terrain, physics, kind, level", CASES[:2])
def test_the_motor_torque_is_the_traction_the_converged_step_gives_the_body(
        monkeypatch, vehicle, terrain, physics, kind, level):
    # the body receives F(V + dv) within the step's tolerance, M tol / dt in force; the
    # traction the motors pay for, mu N per contact, must be that within the same bound
    # (until 2026-11-30 a step whose last Newton step ran on central differences or was
    # halved charged the analytic linearisation of the iterate before: off by up to 0.009
    # of mu per contact on ICE, 0.018 on PACKED_SNOW)
    veh, _, steps = _recorded_run(monkeypatch, vehicle, terrain, physics, kind, level)
    layout = contact_layout(veh.contact_geometry(), veh.mass_kg, 0.0, 1.0)
    worst, inexact = [], 0
    for dt, _, (_, _, _, _, _, exact, returned), end, _, paid in steps:
        np.testing.assert_array_equal(returned.force, end.force)
        worst.append(np.max(np.abs(paid - end.mu) * layout.normal_load_n)
                     / (veh.mass_kg * IMPLICIT_TOLERANCE_PER_S3 * dt))
        inexact += not exact
    assert max(worst) <= 1.0 and inexact > 0


@pytest.mark.parametrize("vehicle, terrain, physics, kind, level", CASES[:2])
def test_the_motor_torque_of_a_step_solved_on_analytic_slopes_is_its_converged_traction(
        monkeypatch, vehicle, terrain, physics, kind, level):
    # the steps whose last Newton step was exact (full, on the contact laws' own slopes)
    # charge the motors the implicit step's linearisation, bit for bit as before
    # 2026-11-30, and that is the traction at the converged twist within the step's
    # tolerance; the other steps charge the converged traction itself (the test above)
    veh, _, steps = _recorded_run(monkeypatch, vehicle, terrain, physics, kind, level)
    layout = contact_layout(veh.contact_geometry(), veh.mass_kg, 0.0, 1.0)
    maps = velocity_maps(layout, np.zeros_like(layout.x_m))
    checked = 0
    for dt, _, (_, lin, last, its, _, exact, _), end, _, paid in steps:
        if not exact:
            np.testing.assert_array_equal(paid, end.mu)
            continue
        np.testing.assert_array_equal(paid, step_traction_coefficient(lin, maps, last))
        assert np.max(np.abs(paid - end.mu) * layout.normal_load_n) <= (
            veh.mass_kg * IMPLICIT_TOLERANCE_PER_S3 * dt)
        checked += its > 0
    assert checked >= 3


@pytest.mark.parametrize("where, force", [("start", np.nan), ("start", np.inf),
                                          ("end", np.nan)])
def test_non_finite_contact_forces_are_refused_with_the_step_named(where, force):
    # a NaN force made dv NaN, returned as the 'best' iterate (its NaN error compares
    # False with everything), and the run went on with NaN states
    good = _contact([1.0, 0.0, 0.0], -np.eye(3))
    bad = _contact([force, 0.0, 0.0])
    first = bad if where == "start" else good
    with pytest.raises(NonFiniteInputError, match=r"step 7 \(t = 0.070 s\)"):
        implicit_euler_step(M, M_INV, 0.01, np.zeros(3), first, first.force,
                            lambda twist: bad, "step 7 (t = 0.070 s)")


@pytest.mark.parametrize("correction", [["a", "b"], "fast", {"l": 1.0}, [1j, 0.0],
                                        [[1.0], [2.0, 3.0]]])
def test_a_hook_correction_that_is_not_numbers_is_refused_naming_the_step(correction):
    # text, a dict or complex numbers were bare ValueErrors / TypeErrors of NumPy
    veh = get_vehicle("husky")
    t = np.arange(0.0, 0.1, 0.01)
    with pytest.raises(TerrainError, match="step 0"):
        integrate(veh, veh.contact_geometry(), (get_terrain("ICE"),), np.inf, t,
                  _commands(t, "ramp", 0.3), 0.0, 1.0, hook=lambda snap: correction)


def test_simconfig_takes_a_generator_of_terrain_names():
    # the terrain checks iterated a generator to its end: the run got no terrain (and the
    # label MIXED) without a word
    config = SimConfig(duration_s=1.0, terrains=(t for t in ["ice", "SNOW"]))
    assert config.terrains == ("ICE", "SNOW") and config.run_terrain == "MIXED"
    assert SimConfig(duration_s=1.0, terrains=iter(["ice"])).run_terrain == "ICE"
    with pytest.raises(ConfigError, match="at least one terrain"):
        SimConfig(duration_s=1.0, terrains=iter([]))


def test_the_run_id_the_simulate_docstring_gives_is_the_run_id():
    run = simulate(SimConfig(vehicle="husky", terrains=("ICE",), scenario="spin",
                             duration_s=0.5, seed=3))
    assert run.run_id == "sim/ICE/spin/3"
    assert "sim/<TERRAIN>/<scenario>/<seed>" in simulate.__doc__
