"""The readers' IMU axes and wheel sides against the filter that consumes them.

The skid-steer slip filter (:mod:`terrain.estimation.skid_steer_slip`) measures the body
frame x forward, y left, z up: ``az = g cos(pitch)`` (+9.81 m/s^2 on level ground) and a
yaw rate ``wz`` positive counter-clockwise, when the right side runs faster than the left
(``vel_r > vel_l``). The simulator writes runs so, and so are the shipped runs. A file in
another convention (an IMU in a z-down frame, FRD as PX4 logs it; the left and right wheel
columns swapped) was read without a word, and every consumer got a mirror image.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import UnitError
from terrain.estimation.skid_steer_slip import (MEASUREMENT_NAMES, STATE_NAMES,
                                                SkidSteerSlipModel)
from terrain.io.measured import read_runs_dir
from terrain.io.plausibility import check_accel_units, check_run
from terrain.io.writer import FLOAT_FORMAT, to_file_frames, write_run
from terrain.run import TIME, Run
from terrain.sim.simulate import SimConfig, simulate


def _consumer_streams(yaw_rate: np.ndarray, speed: float, rate_hz: float = 50.0,
                      wheel_every: int = 5, seed: int = 0) -> dict[str, pd.DataFrame]:
    """IMU and wheel streams as the filter's own measurement model predicts them for a level
    drive at ``speed`` (m/s) with the yaw rate profile ``yaw_rate`` (rad/s, one per IMU
    sample), plus a little noise."""
    model = SkidSteerSlipModel()
    rng = np.random.default_rng(seed)
    levels, which = np.unique(yaw_rate, return_inverse=True)
    h = np.empty((len(levels), len(MEASUREMENT_NAMES)))
    for k, r in enumerate(levels):
        x = np.zeros(len(STATE_NAMES))
        x[STATE_NAMES.index("v_bx")] = speed
        x[STATE_NAMES.index("yaw_rate")] = r
        h[k] = model.h(x)
    m = dict(zip(MEASUREMENT_NAMES, h[which].T))
    t = np.arange(len(yaw_rate)) / rate_hz
    n = len(t)
    imu = pd.DataFrame({TIME: t, "wx": 0.01 * rng.standard_normal(n),
                        "wy": 0.01 * rng.standard_normal(n),
                        "wz": m["wz"] + 0.01 * rng.standard_normal(n),
                        "ax": m["ax"] + 0.1 * rng.standard_normal(n),
                        "ay": 0.1 * rng.standard_normal(n),
                        "az": m["az"] + 0.1 * rng.standard_normal(n)})
    w = slice(None, None, wheel_every)
    wheels = pd.DataFrame({TIME: t[w], "vel_l": m["vel_l"][w], "vel_r": m["vel_r"][w],
                           "cur_l": np.full(len(t[w]), 5.0), "cur_r": np.full(len(t[w]), 5.0)})
    return {"imu": imu, "wheels": wheels}


def _frd(imu: pd.DataFrame) -> pd.DataFrame:
    """The same IMU in a z-down body frame (x forward, y right, z down: FRD)."""
    return imu.assign(**{c: -imu[c] for c in ("wy", "wz", "ay", "az")})


def _swapped(wheels: pd.DataFrame) -> pd.DataFrame:
    """The wheel stream with its left and right columns exchanged."""
    return wheels.rename(columns={"vel_l": "vel_r", "vel_r": "vel_l", "cur_l": "cur_r",
                                  "cur_r": "cur_l"})[list(wheels.columns)]


def _quiet_check_run(streams):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return check_run("r", streams, "husky", {s: s for s in streams})


turns = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=6).filter(
    lambda a: np.ptp(a) > 0.5)


@settings(max_examples=30, deadline=None)
@given(turns, st.floats(0.2, 0.9), st.integers(0, 2**16))
def test_an_imu_in_the_filters_own_axes_passes_and_in_a_z_down_frame_is_refused(
        levels, speed, seed):
    # a yaw rate that steps between levels (turns left and right), sampled at 50 Hz
    streams = _consumer_streams(np.repeat(levels, 150), speed, seed=seed)
    _quiet_check_run({"imu": streams["imu"]})      # the filter's own convention passes
    with pytest.raises(UnitError, match="rule imu_axes") as info:
        _quiet_check_run({"imu": _frd(streams["imu"])})
    assert (info.value.path, info.value.column) == ("imu", "az")
    # the accelerometer's unit rule judges the norm alone: the z-down IMU is in m/s^2
    check_accel_units(_frd(streams["imu"]), "imu", found=[])


@settings(max_examples=30, deadline=None)
@given(turns, st.floats(0.2, 0.9), st.integers(0, 2**16))
def test_wheel_sides_of_the_filters_own_convention_pass_and_swapped_are_refused(
        levels, speed, seed):
    streams = _consumer_streams(np.repeat(levels, 150), speed, seed=seed)
    _quiet_check_run(streams)
    with pytest.raises(UnitError, match="rule wheel_sides"):
        _quiet_check_run({"imu": streams["imu"], "wheels": _swapped(streams["wheels"])})


def test_a_straight_drive_judges_no_wheel_side():
    # no turn: the sides cannot be told apart, and nothing is refused
    streams = _consumer_streams(np.zeros(1000), 0.5)
    _quiet_check_run({"imu": streams["imu"], "wheels": _swapped(streams["wheels"])})


@pytest.fixture(scope="module")
def sim_run():
    return simulate(SimConfig(vehicle="husky", duration_s=20.0, seed=3, scenario="random"))


def _read_back(tmp_path, run: Run):
    write_run(run, tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_runs_dir(tmp_path)


@pytest.mark.slow
def test_a_simulated_run_written_and_read_back_keeps_the_filters_convention(tmp_path, sim_run):
    (back,) = _read_back(tmp_path, sim_run)
    model = SkidSteerSlipModel()
    x = np.zeros(len(STATE_NAMES))
    x[STATE_NAMES.index("yaw_rate")] = 0.3
    expected = dict(zip(MEASUREMENT_NAMES, model.h(x)))
    imu, wheels = back.streams["imu"], back.streams["wheels"]
    # level ground: az has the sign of the model's g cos(pitch)
    assert np.sign(np.median(imu["az"])) == np.sign(expected["az"]) == 1.0
    # wz and the wheel speed difference turn together, as in the model
    wz = np.interp(wheels[TIME], imu[TIME], imu["wz"])
    dv = wheels["vel_r"] - wheels["vel_l"]
    assert np.corrcoef(dv, wz)[0, 1] > 0.9
    assert np.sign(expected["vel_r"] - expected["vel_l"]) == np.sign(expected["wz"])


def _read_back_unchecked(tmp_path, run: Run):
    """As :func:`_read_back`, the files written by hand: write_run refuses a run that the
    readers refuse (review fixio)."""
    folder = tmp_path / run.terrain
    folder.mkdir(parents=True)
    for kind, frame in to_file_frames(run).items():
        frame.to_csv(folder / f"{kind}_00.csv", index=False, float_format=FLOAT_FORMAT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_runs_dir(tmp_path)


def test_a_run_with_an_imu_in_a_z_down_frame_is_refused_by_the_readers(tmp_path, sim_run):
    streams = dict(sim_run.streams, imu=_frd(sim_run.streams["imu"]))
    run = Run(sim_run.run_id, "sim", sim_run.terrain, streams, vehicle="husky")
    with pytest.raises(UnitError, match="rule imu_axes") as info:
        _read_back_unchecked(tmp_path, run)
    assert info.value.column == "az" and str(info.value.path).endswith("imu_00.csv")


def test_a_run_with_its_wheel_sides_swapped_is_refused_by_the_readers(tmp_path, sim_run):
    streams = dict(sim_run.streams, wheels=_swapped(sim_run.streams["wheels"]))
    run = Run(sim_run.run_id, "sim", sim_run.terrain, streams, vehicle="husky")
    with pytest.raises(UnitError, match="rule wheel_sides") as info:
        _read_back_unchecked(tmp_path, run)
    assert info.value.column == "velL" and str(info.value.path).endswith("pro_00.csv")


def test_the_husky_bounds_of_the_unit_rules_are_the_vehicle_models():
    # rule wheel_speed_units judges against the top speed that the vehicle model's motor
    # limit gives, and the gyro rules' slope bound holds for every skid-steer track
    from terrain.io.plausibility import MAX_YAW_SLOPE_PER_M, VEHICLE_LIMITS
    from terrain.vehicles import get_vehicle

    husky = get_vehicle("husky")
    top = husky.motor.max_wheel_speed_rad_s * husky.wheel_radius_m
    assert VEHICLE_LIMITS["husky"].top_speed_m_s == pytest.approx(top, rel=1e-12)
    for name in ("husky", "tracked"):
        assert 1.0 / get_vehicle(name).track_m <= MAX_YAW_SLOPE_PER_M
