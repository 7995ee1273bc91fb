"""Multi-rate run loop: scheduling, skipped and counted samples, outage and recovery."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ShapeError, TimeStepError
from terrain.estimation import Gate, SensorSamples, make_grid, run_filter
from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
from pipelines.validation.harness import outage_experiment, simulate_agrimaro, truth_on_grid


def _straight_samples(n_wheel=300, n_gyro=3001, v=0.5, seed=0):
    rng = np.random.default_rng(seed)
    tw = np.arange(n_wheel) * 0.1
    tg = np.arange(n_gyro) * 0.01
    wheels = np.full((n_wheel, 2), v) + 0.01 * rng.standard_normal((n_wheel, 2))
    gyro = 0.02 + 0.005 * rng.standard_normal((n_gyro, 1))      # a 0.02 rad/s bias
    return {"wheels": SensorSamples(tw, wheels), "gyro": SensorSamples(tg, gyro)}


def test_non_finite_samples_are_skipped_per_row_and_counted():
    samples = _straight_samples()
    w = samples["wheels"].values.copy()
    w[10, 0] = np.nan              # one side missing: the other side is still used
    w[20, :] = np.inf              # whole sample bad
    g = samples["gyro"].values.copy()
    g[100:110] = np.nan
    samples = {"wheels": SensorSamples(samples["wheels"].t_s, w),
               "gyro": SensorSamples(samples["gyro"].t_s, g)}
    grid = make_grid(0.0, 30.0, 100.0)
    settings = SkidSteerSettings(wheel_std_m_s=0.01, gyro_std_rad_s=0.005)  # the true noise
    res = run_filter(SkidSteerModel(settings), grid, samples)
    assert res.counts["wheels"]["non_finite"] == 2
    assert res.counts["gyro"]["non_finite"] == 10
    assert res.counts["wheels"]["used"] == 299         # 300 samples, 1 fully non-finite
    assert res.counts["gyro"]["used"] == 2991
    k10 = np.searchsorted(grid, 1.0 - 1e-9)
    assert not res.accepted[k10, 0] and res.accepted[k10, 1]
    assert np.isfinite(res.x).all() and np.isfinite(res.P_diag).all()
    # driving straight makes the bias observable: within 3 posterior sigmas, sigma < 3 mrad/s
    assert abs(res.state("gyro_bias")[-1] - 0.02) < 3.0 * res.std("gyro_bias")[-1]
    assert res.std("gyro_bias")[-1] < 0.003
    frame = res.to_frame()
    assert {"t_s", "v_bx", "std_v_bx", "innov_vel_l", "innov_wz", "nis", "nis_dof"} <= set(
        frame.columns)
    assert np.isnan(frame["innov_vel_l"].iloc[k10])


def test_superseded_and_outside_samples_are_counted():
    t = np.array([-5.0, 0.001, 0.002, 0.5, 99.0])
    samples = {"gyro": SensorSamples(t, np.zeros((5, 1)))}
    res = run_filter(SkidSteerModel(), make_grid(0.0, 1.0, 100.0), samples)
    c = res.counts["gyro"]
    assert c["outside"] == 2 and c["superseded"] == 1 and c["used"] == 2


def test_bad_inputs_raise():
    grid = make_grid(0.0, 1.0, 10.0)
    with pytest.raises(ShapeError):
        run_filter(SkidSteerModel(), grid, {"camera": SensorSamples(grid, np.zeros((11, 1)))})
    with pytest.raises(ShapeError):
        run_filter(SkidSteerModel(), grid, {"gyro": SensorSamples(grid, np.zeros((11, 2)))})
    with pytest.raises(TimeStepError):
        run_filter(SkidSteerModel(), grid[::-1], {})
    with pytest.raises(TimeStepError):
        SensorSamples(np.array([0.0, 0.0]), np.zeros((2, 1)))
    with pytest.raises(TimeStepError):
        make_grid(0.0, 1.0, 0.0)


@pytest.fixture(scope="module")
def grass_random():
    return simulate_agrimaro("GRASS", seed=2, duration_s=16.0, scenario="random")


def test_camera_outage_covariance_grows_and_recovers(grass_random):
    dropped, nanned = outage_experiment(grass_random, t_off_s=8.0, t_on_s=11.0)
    for res in (dropped, nanned):
        t = res.t_s
        sd = res.std("v_by")
        before = sd[(t > 6.0) & (t < 8.0)].mean()
        during_end = sd[(t > 10.8) & (t < 11.0)].mean()
        after = sd[(t > 13.0) & (t < 16.0)].mean()
        assert during_end > 2.0 * before          # the filter knows it lost the camera
        assert after < 1.3 * before               # and recovers once it is back
        assert np.isfinite(res.x).all()
        assert res.counts["cam"]["used"] > 0
        idle = (t >= 8.02) & (t < 10.98)
        assert not res.accepted[idle][:, list(res.sensor_rows["cam"])].any()
        assert res.accepted[idle][:, list(res.sensor_rows["imu"])].all()   # IMU still used
    assert nanned.counts["cam"]["non_finite"] == 90     # 3 s at 30 Hz, skipped and counted
    # during the outage the velocity rests on the accelerometers and the (slip-blind) wheels:
    # the error grows, mostly inside the filter's own 3-sigma band; after it the error is
    # back to its pre-outage level
    tr = truth_on_grid(grass_random, dropped.t_s)
    t = dropped.t_s
    err = np.abs(dropped.state("v_bx") - tr["v_bx"].to_numpy())
    idle = (t >= 8.0) & (t < 11.0)
    assert err[idle].max() < 0.3
    assert (err[idle] < 3.0 * dropped.std("v_bx")[idle]).mean() > 0.75
    assert err[(t > 12.0)].mean() < 2.0 * err[(t > 5.0) & (t < 8.0)].mean() + 0.005


def test_step_bounds_hold_every_estimate_and_are_counted():
    """Bounds from measurements (per step) are applied after every step by estimate
    projection, the steps where one was active are counted, and the compiled loop, which
    does not apply them, is refused, as are bounds of the wrong shape."""
    from terrain.errors import ConfigError
    from terrain.estimation.skid_steer_slip import SkidSteerSlipModel, SkidSteerSlipSettings
    model = SkidSteerSlipModel(SkidSteerSlipSettings(slip_std=0.01))
    t = np.arange(0.0, 4.0, 0.01)
    # rims at 0.3 m/s and a pseudo slip of -0.6 (braking): the speed the rows ask is 0.75 m/s
    samples = {"wheels": SensorSamples(t[::15], np.full((t[::15].size, 2), 0.3)),
               "slip_model": SensorSamples(t[50::100], np.full((4, 2), -0.6))}
    free = run_filter(model, t, samples, engine="numpy")
    assert free.state("v_bx").max() > 0.6
    upper = np.full((t.size, 8), np.inf)
    upper[:, 0] = 0.45
    held = run_filter(model, t, samples, engine="numpy", step_bounds=(-upper, upper))
    assert held.state("v_bx").max() <= 0.45
    n = held.meta["step_bounds_active"]
    assert 0 < n <= t.size
    # the slips moved with the speed (anti-correlated along v (1 - s) = omega r)
    assert held.state("slip_1")[-1] > free.state("slip_1")[-1]
    assert "step_bounds_active" not in free.meta
    with pytest.raises(ConfigError, match="bounds"):
        run_filter(model, t, samples, engine="numba", step_bounds=(-upper, upper))
    with pytest.raises(ShapeError, match="step_bounds"):
        run_filter(model, t, samples, step_bounds=(-upper[:, :3], upper[:, :3]))
    with pytest.raises(ShapeError, match="above"):
        run_filter(model, t, samples, step_bounds=(upper, -upper))


def test_state_bound_clips_are_counted():
    """The model's state_bounds clip was silent: a start with slip_1 = 1.4 (outside [-1, 1])
    was clipped back to 1 at the first update and nothing in the result said so."""
    from terrain.estimation.skid_steer_slip import SkidSteerSlipModel
    model = SkidSteerSlipModel()
    t = np.arange(0.0, 2.0, 0.01)
    wheels = {"wheels": SensorSamples(t[::10], np.full((t[::10].size, 2), 0.3))}
    x0 = model.x0
    x0[4] = 1.4
    res = run_filter(model, t, wheels, engine="numpy", x0=x0)
    assert np.abs(res.x[:, 4:6]).max() <= 1.0
    assert res.meta["state_bounds_clipped"] == 1
    assert run_filter(model, t, wheels, engine="numpy").meta["state_bounds_clipped"] == 0
    assert "state_bounds_clipped" not in run_filter(SkidSteerModel(), t, wheels).meta


def test_sample_errors_name_the_sensor_and_the_sample():
    """run_filter said 'sensor has 2 columns, the model expects 1' without the sensor, and
    SensorSamples 'sensor timestamps must be finite and strictly increasing' without the
    sample."""
    grid = make_grid(0.0, 1.0, 10.0)
    with pytest.raises(ShapeError, match="sensor 'gyro' has 2 columns, the model expects 1"):
        run_filter(SkidSteerModel(), grid, {"gyro": SensorSamples(grid, np.zeros((11, 2)))})
    with pytest.raises(TimeStepError, match=r"sample 2 at 0.1 s after 0.2 s"):
        SensorSamples(np.array([0.0, 0.2, 0.1]), np.zeros((3, 1)))
    with pytest.raises(TimeStepError, match=r"sample 1 at nan s"):
        SensorSamples(np.array([0.0, np.nan]), np.zeros((2, 1)))


def test_the_later_of_two_samples_in_one_step_is_the_one_used():
    """Scheduling rule: two samples of a sensor inside one step, the later wins (the earlier
    is counted as superseded). The gyro reads 0.1 then 0.3 rad/s inside the first step
    after t = 0; the innovation at that step is 0.3 - h(x_prior)."""
    t = np.array([0.001, 0.009])
    samples = {"gyro": SensorSamples(t, np.array([[0.1], [0.3]]))}
    res = run_filter(SkidSteerModel(), make_grid(0.0, 0.05, 100.0), samples, engine="numpy")
    assert res.counts["gyro"]["superseded"] == 1 and res.counts["gyro"]["used"] == 1
    assert res.y[1, 2] == pytest.approx(0.3)       # prior yaw rate + bias are 0
    assert np.isnan(res.y[[0, 2, 3, 4, 5], 2]).all()


def test_a_sample_up_to_one_step_before_the_grid_is_used_at_the_first_step():
    """The first step takes the samples of the step before ``t_0`` (a sample a few ms before
    a grid that starts at the overlap of the streams is not lost); older ones are outside."""
    grid = make_grid(1.0, 1.1, 100.0)
    samples = {"gyro": SensorSamples(np.array([0.95, 0.995]), np.array([[0.7], [0.2]]))}
    for engine in ("numpy", "numba"):
        res = run_filter(SkidSteerModel(), grid, samples, engine=engine)
        assert res.counts["gyro"]["outside"] == 1 and res.counts["gyro"]["used"] == 1
        assert res.accepted[0, 2] and res.y[0, 2] == pytest.approx(0.2)


def test_sensor_nis_of_a_one_row_sensor_is_the_step_nis():
    """``sensor_nis`` sums ``y_i^2 / S_ii`` over the sensor's accepted rows: for the gyro
    alone at a step it is that step's NIS, and NaN where the gyro had no sample."""
    t = np.array([0.013, 0.031])
    samples = {"gyro": SensorSamples(t, np.array([[0.2], [-0.1]]))}
    res = run_filter(SkidSteerModel(), make_grid(0.0, 0.05, 100.0), samples, engine="numpy")
    nis = res.sensor_nis("gyro")
    used = np.isfinite(res.nis)
    assert used.sum() == 2
    np.testing.assert_allclose(nis[used], res.nis[used], rtol=1e-12)
    np.testing.assert_allclose(nis[used], res.y[used, 2] ** 2 / res.S_diag[used, 2])
    assert np.isnan(nis[~used]).all()


def test_a_non_finite_sample_does_not_supersede_a_finite_one_in_its_step():
    """The gyro reads 0.3 rad/s, then NaN inside the same step: the NaN sample is skipped and
    counted as non-finite, and the 0.3 is used (not counted as superseded and lost)."""
    t = np.array([0.002, 0.008])
    samples = {"gyro": SensorSamples(t, np.array([[0.3], [np.nan]]))}
    for engine in ("numpy", "numba"):
        res = run_filter(SkidSteerModel(), make_grid(0.0, 0.05, 100.0), samples,
                         engine=engine)
        c = res.counts["gyro"]
        assert (c["non_finite"], c["superseded"], c["used"]) == (1, 0, 1)
        assert res.accepted[1, 2] and res.y[1, 2] == pytest.approx(0.3)


def test_the_frame_shows_only_the_innovations_of_the_rows_used():
    """``to_frame``'s ``innov_<row>`` is the innovation where the row entered the update and
    NaN where the gate rejected it (its innovation is still in ``y``), so that averages of the
    column describe the update; the gate rejects a 5 m/s wheel outlier."""
    samples = _straight_samples()
    w = samples["wheels"].values.copy()
    w[50, 1] = 5.0
    samples["wheels"] = SensorSamples(samples["wheels"].t_s, w)
    res = run_filter(SkidSteerModel(), make_grid(0.0, 30.0, 100.0), samples,
                     gate=Gate(0.999))
    assert res.counts["wheels"]["rejected"] == 1
    frame = res.to_frame()
    k = int(np.flatnonzero(np.isfinite(res.y[:, 1]) & ~res.accepted[:, 1])[0])
    assert res.y[k, 1] > 4.0 and np.isnan(frame["innov_vel_r"].iloc[k])
    np.testing.assert_array_equal(frame["innov_vel_r"].notna(), res.accepted[:, 1])
    used = res.accepted[:, 2]
    np.testing.assert_allclose(frame["innov_wz"][used], res.y[used, 2])


def test_a_sample_exactly_one_step_before_the_grid_is_outside():
    """A sample at ``t_0 - dt`` belongs to the step before ``t_0`` (the placement rule of
    ``step_index``: a sample on a step belongs to that step), which is not part of the grid:
    it is outside, as any older sample; one a microsecond later is the first step's."""
    grid = make_grid(1.0, 1.1, 100.0)
    for t_before, outside in ((0.99, 1), (0.990001, 0)):
        samples = {"gyro": SensorSamples(np.array([t_before]), np.array([[0.7]]))}
        for engine in ("numpy", "numba"):
            res = run_filter(SkidSteerModel(), grid, samples, engine=engine)
            assert res.counts["gyro"]["outside"] == outside
            assert res.counts["gyro"]["used"] == 1 - outside
            assert np.isfinite(res.y[0, 2]) == (outside == 0)


def test_the_reference_loop_uses_a_sample_on_any_row_of_a_model_with_many_rows():
    """The reference loop keyed each step's set of rows by ``sum(2^row)`` in int64: with 70
    rows, a sample on row 64 made no key (2^64 does not fit), so it was silently dropped and
    counted as ``rejected`` with no gate. Row 64 is used and weighs like row 0."""
    from terrain.estimation.model import StateSpaceModel

    m = 70

    class ManyRows(StateSpaceModel):
        """One state seen directly by each of 70 one-row sensors (noise 1)."""

        state_names = ("a",)
        measurement_names = tuple(f"r{i}" for i in range(m))
        sensor_rows = {f"s{i}": (i,) for i in range(m)}
        R_diag = np.ones(m)
        x0 = np.zeros(1)
        P0 = np.eye(1)

        def f(self, x, dt):
            return x.copy()

        def F(self, x, dt):
            return np.eye(1)

        def h(self, x):
            return np.repeat(x, m)

        def H(self, x):
            return np.ones((m, 1))

        def Q(self, dt):
            return np.zeros((1, 1))

    samples = {"s64": SensorSamples(np.array([1.0]), np.array([[1.0]])),
               "s0": SensorSamples(np.array([2.0]), np.array([[1.0]]))}
    res = run_filter(ManyRows(), np.arange(3.0), samples, engine="numpy")
    assert res.accepted[:, 64].tolist() == [False, True, False]
    assert res.dof.tolist() == [0, 1, 1]
    np.testing.assert_allclose(res.x[:, 0], [0.0, 0.5, 2.0 / 3.0])   # P 1 -> 1/2 -> 1/3
    assert res.counts["s64"]["used"] == 1 and res.counts["s64"]["rejected"] == 0
    # a sample at every step (no step without a row): each is used once
    samples["s69"] = SensorSamples(np.array([0.0]), np.array([[1.0]]))
    res = run_filter(ManyRows(), np.arange(3.0), samples, engine="numpy")
    assert res.dof.tolist() == [1, 1, 1]
    np.testing.assert_allclose(res.x[:, 0], [0.5, 2.0 / 3.0, 0.75])
