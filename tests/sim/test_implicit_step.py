"""The implicit-Euler step of the integrator: Newton iterations from the linearly implicit step."""

import numpy as np
import pytest

import terrain.sim.dynamics as dynamics
from terrain.sim import SimConfig, simulate
from terrain.sim.dynamics import (IMPLICIT_TOLERANCE_PER_S3, implicit_euler_step, integrate)
from terrain.sim.forces import ContactForces
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

M = np.diag([50.0, 50.0, 2.0])
M_INV = np.linalg.inv(M)


def _contact(force, jacobian):
    return ContactForces(np.asarray(force, float), np.asarray(jacobian, float), np.zeros(4),
                         np.zeros(4), np.zeros(4))


def test_a_linear_force_is_solved_by_the_first_step_bit_for_bit():
    # F(V) = F0 + K V: the linearly implicit step solves the implicit equation exactly, so no
    # further iteration runs and dV is the one linear solve
    k = np.array([[-80.0, 5.0, 0.0], [3.0, -120.0, 1.0], [0.0, 2.0, -9.0]])
    f0 = np.array([20.0, -4.0, 1.5])
    vel = np.array([0.4, 0.01, 0.2])
    first = _contact(f0 + k @ vel, k)
    gravity = np.array([-3.0, 0.5, 0.0])
    dv, lin, last, its, ok, exact, _ = implicit_euler_step(
        M, M_INV, 0.01, vel, first, first.force + gravity,
        lambda twist: _contact(f0 + k @ twist, k))
    assert ok and its == 0 and lin is first and exact
    np.testing.assert_array_equal(dv, np.linalg.solve(M - 0.01 * k, 0.01 * (first.force
                                                                            + gravity)))
    np.testing.assert_array_equal(last, dv)


def test_a_saturating_force_is_iterated_to_the_implicit_euler_solution():
    # F(v) = -F_max tanh(v / u) along x, linearised with its secant (as the contact laws are):
    # the step must end where M dv = dt F(v + dv) within the tolerance, which the first step
    # alone misses by far
    f_max, u, dt = 400.0, 0.02, 0.01

    def at(twist):
        v = twist[0]
        force = np.array([-f_max * np.tanh(v / u), 0.0, 0.0])
        secant = -f_max * np.tanh(v / u) / v if v else -f_max / u
        return _contact(force, np.diag([secant, 0.0, 0.0]))

    vel = np.array([0.5, 0.0, 0.0])
    first = at(vel)
    dv, _, _, its, ok, _, _ = implicit_euler_step(M, M_INV, dt, vel, first, first.force, at)
    assert ok and its >= 1
    residual = dt * at(vel + dv).force - M @ dv
    assert np.abs(M_INV @ residual).max() <= IMPLICIT_TOLERANCE_PER_S3 * dt * dt
    # the linearly implicit step alone: its residual is far above the tolerance
    lin = np.linalg.solve(M - dt * first.jacobian, dt * first.force)
    assert np.abs(M_INV @ (dt * at(vel + lin).force - M @ lin)).max() > 10 * dt * dt


def test_a_singular_implicit_matrix_is_refused_with_the_step_named():
    zero = np.zeros((3, 3))
    first = _contact([1.0, 0.0, 0.0], zero)
    with pytest.raises(np.linalg.LinAlgError, match="step 3"):
        implicit_euler_step(zero, zero, 0.01, np.zeros(3), first, first.force,
                            lambda twist: first, "step 3 (t = 0.030 s)")


def test_steps_stopped_at_the_iteration_limit_are_counted_and_noted(monkeypatch):
    # a Husky ramping at the friction limit of ice needs iterations; with none allowed every
    # such step is counted, in the physics result, the run's metadata and the CLI's note
    from pipelines.simulate import unconverged_steps_note

    veh = get_vehicle("husky")
    t = np.arange(0.0, 1.0, 0.01)
    tw = np.zeros((len(t), 3))
    tw[:, 0] = np.minimum(0.5 * (t + 0.01), 0.5)
    args = (veh, veh.contact_geometry(), (get_terrain("ICE"),), np.inf, t, tw, 0.0, 1.0)
    full = integrate(*args)
    assert full.implicit_iterations > 0 and full.implicit_unconverged_steps == 0
    monkeypatch.setattr(dynamics, "IMPLICIT_MAX_ITERATIONS", 0)
    capped = integrate(*args)
    assert capped.implicit_iterations == 0
    assert 0 < capped.implicit_unconverged_steps < len(t)
    run = simulate(SimConfig(vehicle="husky", terrains=("ICE",), scenario="straight_accel",
                             duration_s=4.0, seed=0))
    assert run.meta["implicit_unconverged_steps"] > 0
    assert run.meta["implicit_iterations"] == 0
    note = unconverged_steps_note(run)
    assert note.startswith(f"note: {run.meta['implicit_unconverged_steps']} physics step")
    monkeypatch.undo()
    again = simulate(SimConfig(vehicle="husky", terrains=("ICE",), scenario="straight_accel",
                               duration_s=4.0, seed=0))
    assert again.meta["implicit_unconverged_steps"] == 0
    assert unconverged_steps_note(again) is None


def test_a_kink_the_analytic_slopes_miss_is_solved_by_differences_and_backtracking():
    # a wheel held at rest under a body rolling at 0.0202 m/s on a tyre law that holds its
    # friction peak beyond a tiny slip speed (physics v2 on rigid ground): the law reports
    # slope 0 there, so plain Newton steps jump across v = 0 and cycle (+-0.15 m/s of
    # velocity error, step to step); the step must still end where M dv = dt F(v + dv)
    f_peak, u, dt = 390.0, 1e-3, 0.01

    def at(twist):
        v = twist[0]
        force = np.array([-f_peak * np.clip(v / u, -1.0, 1.0), 0.0, 0.0])
        return _contact(force, np.zeros((3, 3)))          # the held peak: slope 0

    vel = np.array([0.0202, 0.0, 0.0])
    first = at(vel)
    dv, _, _, its, ok, _, _ = implicit_euler_step(M, M_INV, dt, vel, first, first.force, at)
    assert ok and its <= 10
    residual = dt * at(vel + dv).force - M @ dv
    assert np.abs(M_INV @ residual).max() <= IMPLICIT_TOLERANCE_PER_S3 * dt * dt
    assert abs(vel[0] + dv[0]) < u                        # stopped, not reversed


def _replay_steps(monkeypatch, run_id: str, physics: str) -> np.ndarray:
    """(Newton iterations, converged) of every implicit step of a shipped run's replay."""
    import terrain.audit.replay as replay
    from terrain.io.shipped import load_dataset

    steps = []

    def counting(*args, **kwargs):
        out = implicit_euler_step(*args, **kwargs)
        steps.append(out[3:5])
        return out

    monkeypatch.setattr(dynamics, "implicit_euler_step", counting)
    run = next(r for r in load_dataset(run_id.split("/")[0]) if r.run_id == run_id)
    replay.replay_run(run, replay.ReplaySettings(physics=physics))
    return np.array(steps, dtype=int)


@pytest.mark.slow
def test_the_v2_replay_of_a_rigid_surface_run_converges_on_every_step(monkeypatch):
    # BorealTC ASPHALT/02 under physics v2 (the tyre's combined-slip law): 26 of its 985 steps
    # stopped unconverged at 50 iterations, the kept iterate swinging v_x between -0.072
    # and -0.075 m/s step to step, before the backtracking and the difference Jacobian
    steps = _replay_steps(monkeypatch, "borealtc/ASPHALT/02", "v2")
    assert len(steps) > 900 and steps[:, 1].all()
    assert steps[:, 0].max() <= 10 and steps[:, 0].sum() > 0


@pytest.mark.slow     # a 622 s replay: ~11 s
def test_the_v1_replay_of_the_longest_flooring_run_converges_on_every_step(monkeypatch):
    # BorealTC FLOORING/06 under physics v1: with the backtracking taking the smallest halving
    # when none lowered the error, 162 of its 62 216 steps stopped unconverged (a step towards
    # a root whose residual rises on the way); the full step is now taken then
    steps = _replay_steps(monkeypatch, "borealtc/FLOORING/06", "v1")
    assert len(steps) > 60_000 and steps[:, 1].all()
    assert steps[:, 0].max() <= 10
