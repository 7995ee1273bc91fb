"""Review fixio of :func:`terrain.io.writer.write_run`: a run that the readers' plausibility
rules (:mod:`terrain.io.plausibility`) would refuse is refused before anything is written,
with the reader's own message (the same rules called, not a copy)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError, DataFormatError
from terrain.io.measured import read_folder_run
from terrain.io.writer import to_file_frames, write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _run(imu_t0_s: float = 0.0) -> Run:
    rng = np.random.default_rng(1)
    imu = pd.DataFrame({TIME: imu_t0_s + np.arange(300) / 100.0,
                        **{c: rng.normal(0.0, 0.1, 300) for c in IMU_CHANNELS}})
    imu["az"] += 9.81
    wheels = pd.DataFrame({TIME: np.arange(20) / 6.5,
                           **{c: rng.uniform(0.0, 0.5, 20) for c in WHEEL_CHANNELS}})
    return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
               streams={"imu": imu, "wheels": wheels}, vehicle="husky", source="", meta={})


def _z_down() -> Run:
    run = _run()
    for c in ("wy", "wz", "ay", "az"):      # x forward, y right, z down
        run.streams["imu"][c] *= -1
    return run


def _in_g() -> Run:
    run = _run()
    for c in ("ax", "ay", "az"):
        run.streams["imu"][c] /= 9.81
    return run


def _gyro_out_of_range() -> Run:
    run = _run()
    run.streams["imu"].loc[120, "wz"] = 80.0       # rad/s, beyond a MEMS gyro's range
    return run


def _clocks_apart() -> Run:
    return _run(imu_t0_s=5000.0)


def _reader_message(run: Run, folder, out) -> str:
    """What the readers say of the run's files written by hand (without write_run's checks),
    as they would name the files write_run writes under ``out``."""
    folder.joinpath(run.terrain).mkdir(parents=True)
    for kind, frame in to_file_frames(run).items():
        frame.to_csv(folder / run.terrain / f"{kind}_00.csv", index=False, float_format="%.9g")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataFormatError) as refused:
            read_folder_run(folder / run.terrain)
    return str(refused.value).replace(str(folder), str(out))


@pytest.mark.parametrize("make, rule", [(_z_down, "imu_axes"), (_in_g, "accel_units"),
                                        (_gyro_out_of_range, "wz"),
                                        (_clocks_apart, "clock_overlap")])
def test_a_run_the_readers_would_refuse_is_refused_before_writing_with_their_message(
        tmp_path, make, rule):
    # an IMU in a z-down frame (az -9.81), an accelerometer in g, a gyro rate beyond its
    # range or clocks that do not overlap were written, then refused by every reader (which
    # stopped the reading of every run of the folder); now ConfigError, nothing written
    run, out = make(), tmp_path / "out"
    said = _reader_message(run, tmp_path / "by_hand", out)
    assert rule in said
    with pytest.raises(ConfigError) as refused:
        write_run(run, out, 0)
    assert said in str(refused.value)
    assert isinstance(refused.value.__cause__, DataFormatError)
    assert not out.exists() or not any(out.rglob("*"))


def test_a_plausible_run_is_written_and_the_readers_findings_are_theirs_to_warn(tmp_path):
    # a stuck gyro axis is a finding (warned on reading), not a refusal: written, and the
    # writer's check says nothing itself (the readers say it on every read)
    run = _run()
    run.streams["imu"].loc[50:250, "wx"] = 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        paths = write_run(run, tmp_path, 0)
    with pytest.warns(UserWarning, match="stuck"):
        back = read_folder_run(paths["pro"].parent)
    np.testing.assert_allclose(back.streams["imu"].to_numpy(), run.streams["imu"].to_numpy(),
                               rtol=5e-9)


@pytest.mark.slow
def test_a_simulated_run_with_its_wheel_sides_swapped_is_refused_before_writing(tmp_path):
    # rule wheel_sides judges the run (check_run): a simulated drive with its left and right
    # wheel columns exchanged was written, then refused by every reader
    from terrain.sim.simulate import SimConfig, simulate

    sim = simulate(SimConfig(vehicle="husky", duration_s=20.0, seed=3, scenario="random"))
    wheels = sim.streams["wheels"]
    swapped = wheels.rename(columns={"vel_l": "vel_r", "vel_r": "vel_l", "cur_l": "cur_r",
                                     "cur_r": "cur_l"})[list(wheels.columns)]
    run = Run(sim.run_id, "sim", sim.terrain, dict(sim.streams, wheels=swapped),
              vehicle="husky", meta=dict(sim.meta))
    out = tmp_path / "out"
    said = _reader_message(run, tmp_path / "by_hand", out)
    assert "rule wheel_sides" in said
    with pytest.raises(ConfigError) as refused:
        write_run(run, out, 0)
    assert said in str(refused.value)
    assert not out.exists() or not any(out.rglob("*"))
    write_run(sim, out, 0)      # the run as simulated is written and reads back
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = read_folder_run(out / sim.terrain)
    assert back.meta["scenario"] == "random"
