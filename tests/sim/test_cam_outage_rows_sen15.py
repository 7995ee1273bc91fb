"""Simulated visual-odometry outages never leave the camera file with fewer rows than the
readers need (review sen15)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from terrain.io.measured import read_folder_run
from terrain.io.writer import write_run
from terrain.sim import SimConfig, simulate
from terrain.sim.sensors import sample_times
from terrain.sim.simulate import DEFAULT_SENSORS, MIN_STREAM_SAMPLES


def test_an_outage_that_would_leave_the_camera_under_two_rows_is_not_planted(tmp_path):
    """AgriMaRo, 0.5 s, seed 270: an outage from 0.031 to 0.591 s dropped every camera row
    but the first, so the written ``cam_00.csv`` held one row and reading the run back
    failed (EmptyFileError: 'at least 2 are needed to know the sample rate'). The outage is
    now left out (not listed in ``cam_outages_s``) and the run reads back."""
    run = simulate(SimConfig(vehicle="agrimaro", scenario="spin", duration_s=0.5, seed=270))
    assert len(run.streams["cam"]) >= MIN_STREAM_SAMPLES
    t_all = np.arange(0.0, 0.5 + 1e-9, 1.0 / 30.0)
    inside = np.zeros(len(t_all), dtype=bool)
    for start, end in run.meta["cam_outages_s"]:
        inside |= (t_all >= start) & (t_all < end)
    assert run.meta["cam_rows_dropped"] == int(inside.sum())
    np.testing.assert_array_equal(run.streams["cam"]["t_s"], t_all[~inside])
    back = read_folder_run(write_run(run, tmp_path)["meta"].parent)
    assert len(back.streams["cam"]) == len(run.streams["cam"])


@pytest.mark.slow
@settings(max_examples=30, deadline=None)
@given(steps=st.integers(4, 300), seed=st.integers(0, 2**31 - 1),
       rate=st.floats(0.0, 40.0))
def test_every_simulated_camera_stream_keeps_two_rows_and_its_outages_add_up(
        steps, seed, rate):
    sensors = replace(DEFAULT_SENSORS["agrimaro"], cam_outage_rate_hz=rate)
    duration = steps / 100.0
    run = simulate(SimConfig(vehicle="agrimaro", scenario="spin", duration_s=duration,
                             seed=seed, sensors=sensors))
    cam = run.streams["cam"]["t_s"].to_numpy()
    assert len(cam) >= MIN_STREAM_SAMPLES
    t_all = sample_times(run.meta["duration_s"], sensors.cam_rate_hz)
    inside = np.zeros(len(t_all), dtype=bool)
    for start, end in run.meta["cam_outages_s"]:
        assert 0.5 <= end - start <= 2.0 and 0.0 <= start <= duration
        inside |= (t_all >= start) & (t_all < end)
    assert run.meta["cam_rows_dropped"] == int(inside.sum())
    np.testing.assert_array_equal(cam, t_all[~inside])
