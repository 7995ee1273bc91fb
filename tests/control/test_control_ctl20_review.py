"""Review ctl20: metamorphic relations between the control layer's public entry points."""

import itertools

import numpy as np

import pytest
from hypothesis import given, settings, strategies as st

from terrain.control import grid
from terrain.control.closed_loop import fallback_basis
from terrain.control.desired_slip import build_slip_table
from terrain.control.feedforward import traction_acceleration_limit
from terrain.terramechanics import get_terrain


def _fake_loop(cost_of):
    """A stand-in for run_closed_loop whose controlled runs score ``cost_of(kp, ki)``."""
    def run(vehicle, terrain, scenario, on, seed, duration_s, gains=None, **kwargs):
        rmse = cost_of(*gains) if on else 0.5
        return None, None, {"time_to_speed_s": 2.0, "slip_rmse": rmse,
                            "steady_slip_within_0_02": 1.0}
    return run


@settings(max_examples=40, deadline=None)
@given(kp=st.lists(st.sampled_from([0.5, 1.0, 2.0, 5.0, 10.0, 20.0]), min_size=1, max_size=4,
                   unique=True),
       ki=st.lists(st.sampled_from([0.0, 1.0, 10.0]), min_size=1, max_size=3, unique=True),
       data=st.data())
def test_tuned_gains_do_not_depend_on_the_order_of_the_grids(kp, ki, data):
    """Tied candidates (docs: every Husky candidate costs the same once the feed-forward
    does the work) gave the first of the grid's order: kp grid (5, 2) tuned kp 5, (2, 5)
    kp 2. The best pair must not depend on the order the candidates are listed in."""
    flat = data.draw(st.booleans())
    cost = (lambda kp_, ki_: 0.09) if flat else (lambda kp_, ki_: 0.09 + 0.001 * (ki_ > 5))
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(grid, "run_closed_loop", _fake_loop(cost))
        best, table = grid.tune_gains("husky", ["ICE"], kp, ki)
        best_rev, table_rev = grid.tune_gains("husky", ["ICE"], kp[::-1], ki[::-1])
    finally:
        mp.undo()
    assert best == best_rev
    costs = {(r.kp, r.ki): r.cost for r in table.itertuples()}
    assert costs[best] == min(costs.values())
    # ties: the smallest gains, as the default gains were kept (closed_loop.DEFAULT_GAINS)
    tied = [k for k, c in costs.items() if c == costs[best]]
    assert best == min(tied)
    assert sorted(itertools.product(kp, ki)) == sorted(costs)


# --- the fallback's terrain does not depend on the order of the table's classes ---------------

TIED = ("SNOW", "SANDY_LOAM", "GRASS", "GRAVEL")   # traction target 0.30 each (the cap)


@pytest.mark.slow
@settings(max_examples=30, deadline=None)
@given(classes=st.permutations(TIED + ("DIRT_ROAD", "PLOUGHED")),
       size=st.integers(2, 6))
def test_the_fallback_basis_does_not_depend_on_the_order_of_the_classes(classes, size):
    """A table of SANDY_LOAM and GRAVEL (both at the 0.30 cap) assumed SANDY_LOAM's curve
    while undecided (feed-forward a_max 1.59 m/s^2), GRAVEL and SANDY_LOAM GRAVEL's
    (0.56 m/s^2): the first listed. The conservative case is the terrain of the fallback's
    traction target that lets the robot accelerate least, in any order."""
    chosen = list(classes[:size])
    basis = fallback_basis(build_slip_table(chosen))
    assert basis == fallback_basis(build_slip_table(chosen[::-1]))
    table = build_slip_table(chosen)
    assert table.entries[basis].traction == table.fallback.traction
    tied = [e for e in table.entries.values() if e.traction == table.fallback.traction]
    limits = {e.terrain: traction_acceleration_limit(get_terrain(e.terrain), e.traction)
              for e in tied}
    assert limits[basis] == min(limits.values())


# --- an estimator's answer does not depend on where its clock starts -------------------------

_RECORDED = {}


def _observations(vehicle="agrimaro", duration_s=1.5):
    """The observations of a simulated start on SNOW (recorded once per vehicle)."""
    if vehicle not in _RECORDED:
        from terrain.sim.closed_loop import simulate_closed_loop
        from terrain.sim.simulate import SimConfig
        seen = []

        def record(obs):
            seen.append(obs)
            return np.zeros(len(obs.omega_low_level))

        simulate_closed_loop(SimConfig(vehicle=vehicle, terrains=("SNOW",),
                                       scenario="straight_accel", duration_s=duration_s,
                                       seed=4), record)
        _RECORDED[vehicle] = seen
    return _RECORDED[vehicle]


def _shifted(obs, c):
    """The observation with every clock (the call's, each sample's) moved by ``c`` s."""
    moved = {f: (a.copy() if a.size else a) for f, a in obs._asdict().items()
             if f not in ("t_s", "omega_low_level")}
    for a in moved.values():
        if a.size:
            a[:, 0] += c
    return obs._replace(t_s=obs.t_s + c, **moved)


@pytest.mark.parametrize("imu", ["full-gyro", "clean", "full-averaged"])
@pytest.mark.parametrize("shift", [-30.0, 0.25, 1000.0])
def test_the_agrimaro_estimate_does_not_depend_on_where_the_clock_starts(imu, shift):
    """The AgriMaRo EKF started its clock at 0 s: a log stamped from 1000 s began with one
    prediction over 1000 s (its covariance blown up: another estimate for seconds), one
    stamped before 0 s (a negative clock) never predicted until the clock passed 0."""
    from terrain.control.estimators import AgriMaRoVisualOdometryEKF
    obs = _observations()
    ref, moved = AgriMaRoVisualOdometryEKF(imu=imu), AgriMaRoVisualOdometryEKF(imu=imu)
    for o in obs:
        a, b = ref.update(o), moved.update(_shifted(o, shift))
        for name in ("v_long_m_s", "a_local_m_s2", "chassis_speed_m_s", "age_s"):
            np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-6,
                                       atol=1e-6, err_msg=f"{name} at {o.t_s}")


def _straight(obs):
    """The observation without lateral acceleration (``ay`` 0): its centripetal part
    ``v_x w_z`` keeps its sign when the manoeuvre is driven backwards."""
    moved = {f: getattr(obs, f).copy() for f in ("imu", "imu_full")}
    for field, col in (("imu", 2), ("imu_full", 5)):
        if moved[field].size:
            moved[field][:, col] = 0.0
    return obs._replace(**moved)


def _reversed(obs):
    """The same manoeuvre driven backwards: wheel speeds, commands, the camera's and the
    IMU's velocities, accelerations and turn rates negated (gravity ``az`` and the steering
    angles kept)."""
    moved = {f: getattr(obs, f).copy() for f in ("imu", "wheels", "cam", "imu_full")}
    for field, cols in (("imu", (1, 2, 3)), ("wheels", slice(1, None)), ("cam", (1, 2, 3)),
                        ("imu_full", (1, 3, 4, 5))):
        if moved[field].size:
            moved[field][:, cols] *= -1
    return obs._replace(omega_low_level=-obs.omega_low_level, **moved)


def _assert_mirrored(vehicle, kind, obs):
    from terrain.control.estimators import estimator_for
    fwd = estimator_for(vehicle, lambda t: ("SNOW", 1.0), kind)
    back = estimator_for(vehicle, lambda t: ("SNOW", 1.0), kind)
    for o in map(_straight, obs):
        a, b = fwd.update(o), back.update(_reversed(o))
        for name in ("v_long_m_s", "a_local_m_s2"):
            np.testing.assert_allclose(getattr(b, name), -np.asarray(getattr(a, name)),
                                       atol=1e-9, err_msg=f"{name} at {o.t_s}")
        np.testing.assert_allclose(b.chassis_speed_m_s, a.chassis_speed_m_s, atol=1e-9)


def test_the_husky_observer_estimate_of_the_manoeuvre_driven_backwards_is_mirrored():
    """Eqs. 8.7-8.9 take the target's sign from the estimated v_long: a manoeuvre driven
    backwards must give the negated speeds and accelerations, or the controller regulates a
    reversing robot to another slip than a forward one."""
    _assert_mirrored("husky", "observer", _observations("husky", 2.0))


# the fused observer's pseudo-measurement at standstill (rim speed 0, a current of 0.16 A)
# was taken as driving forward (+0.016) whichever way the robot then drove
def test_the_fused_estimate_of_the_manoeuvre_driven_backwards_is_mirrored():
    _assert_mirrored("husky", "fused", _observations("husky", 2.0))


@pytest.mark.parametrize("shift", [-30.0, 1000.0])
def test_the_loop_does_not_depend_on_where_the_clock_starts(shift):
    """The whole robot side (AgriMaRo estimator, table look-up with a stamped, then stale
    decision, PID and feed-forward) on every clock moved by ``shift`` gives the same
    corrections and the same fallback steps."""
    from terrain.control.closed_loop import TractionLoop
    from terrain.control.estimators import estimator_for
    from terrain.control.traction import config_for_vehicle
    cfg, n = config_for_vehicle("agrimaro", kp=5.0, ki=3.0, max_input_age_s=0.5)
    table = build_slip_table(["SNOW", "ICE"])

    def loop(c):
        def decision(t):   # stamped 10 ms back after 0.3 s, of unknown time before
            return ("SNOW", 0.9, (t - 0.01) if t > 0.3 + c else None)
        return TractionLoop(cfg, n, estimator_for("agrimaro", lambda t: ("SNOW", 1.0)),
                            table, decision)

    ref, moved = loop(0.0), loop(shift)
    for o in _observations():
        np.testing.assert_allclose(moved(_shifted(o, shift)), ref(o), atol=1e-9)
    assert [r["fallback"] for r in moved.log] == [r["fallback"] for r in ref.log]
    assert any(r["fallback"] for r in ref.log) and not all(r["fallback"] for r in ref.log)
