"""Windowing review: the book-keeping states what was aligned."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features.windows import WindowConfig, make_windows
from terrain.errors import MissingColumnError
from terrain.io.report import input_report
from terrain.run import IMU_CHANNELS, TIME, Run


def _run() -> Run:
    """IMU at 100 Hz over 0-20 s, wheels at 10 Hz over 3-20 s at a steady 0.5 m/s."""
    ti = np.arange(2001) / 100.0
    rng = np.random.default_rng(0)
    imu = pd.DataFrame({TIME: ti, **{c: 0.05 * rng.standard_normal(ti.size)
                                     for c in IMU_CHANNELS}})
    tw = 3.0 + np.arange(171) / 10.0
    wheels = pd.DataFrame({TIME: tw, "vel_l": 0.5, "vel_r": 0.5, "cur_l": 5.0, "cur_r": 5.0})
    return Run(run_id="t/ICE/00", dataset="t", terrain="ICE",
               streams={"imu": imu, "wheels": wheels}, source="in-memory test run",
               meta={"unused_s": {"imu": 3.0}})


def test_steady_only_records_the_wheel_stream_it_aligns_for_imu_signals():
    # steady_only aligns the wheels beside the IMU whatever the signals, so the IMU is cut
    # to the wheels' span (3-20 s): the 3 s before it are unused and the report says so
    run = _run()
    ws = make_windows([run], "imu", WindowConfig(window_s=2.0, steady_only=True))
    assert ws.t_start_s.min() == pytest.approx(3.0)
    assert ws.counts["streams"] == ["imu", "wheels"]
    row = input_report([run], ws.counts, 2.0).table.iloc[0]
    assert row["unused_imu_s"] == pytest.approx(3.0)
    # without steady_only only the IMU is aligned: all of it is windowed, nothing unused
    plain = make_windows([run], "imu", WindowConfig(window_s=2.0))
    assert plain.t_start_s.min() == pytest.approx(0.0) and plain.counts["streams"] == ["imu"]
    assert input_report([run], plain.counts, 2.0).table.iloc[0]["unused_imu_s"] == 0.0


def _plain_run(run_id: str = "t/ICE/01", duration_s: float = 12.0, hole=None) -> Run:
    """IMU at 100 Hz and wheels at 10 Hz over [0, duration_s]; ``hole``: ``(a, b)`` s with
    no wheel sample strictly inside (a timestamp gap of the wheel stream)."""
    ti = np.arange(int(round(duration_s * 100)) + 1) / 100.0
    rng = np.random.default_rng(1)
    imu = pd.DataFrame({TIME: ti, **{c: 0.05 * rng.standard_normal(ti.size)
                                     for c in IMU_CHANNELS}})
    tw = np.arange(int(round(duration_s * 10)) + 1) / 10.0
    if hole is not None:
        tw = tw[(tw <= hole[0]) | (tw >= hole[1])]
    wheels = pd.DataFrame({TIME: tw, "vel_l": 0.5, "vel_r": 0.6, "cur_l": 5.0, "cur_r": 6.0})
    return Run(run_id=run_id, dataset="t", terrain="ICE",
               streams={"imu": imu, "wheels": wheels}, source="in-memory test run")


def test_chained_subsets_keep_every_runs_not_selected_count():
    # a subset of a subset counts, per run, the windows of the original set it leaves out:
    # run 02 (10 windows) was already left out by the first selection and stays so
    runs = [_plain_run("t/ICE/01", 20.0), _plain_run("t/ICE/02", 20.0)]
    ws = make_windows(runs, "all", WindowConfig(window_s=2.0))
    first = ws.subset(ws.run_ids == "t/ICE/01")
    second = first.subset(np.array([0, 2]))
    per = second.counts["per_run"]
    assert {r: (e["windows"], e["not_selected"]) for r, e in per.items()} == {
        "t/ICE/01": (2, 8), "t/ICE/02": (0, 10)}
    assert second.counts["not_selected"] == sum(e["not_selected"] for e in per.values()) == 18


@pytest.mark.parametrize("partition_s", [None, 5.0])
def test_every_aligned_second_is_a_window_position_or_a_counted_tail(partition_s):
    # 12.3 s of IMU and wheels at 50 Hz are 616 samples, 12.32 s (each sample one period);
    # 2 s windows without overlap: 6 positions and 0.32 s after the last one; with 5 s
    # partitions: 2 partitions of 2 windows (1 s after each) and 2.32 s after the last one
    run = _plain_run(duration_s=12.3)
    ws = make_windows([run], "all", WindowConfig(window_s=2.0, partition_s=partition_s))
    c = ws.counts["per_run"]["t/ICE/01"]
    assert c["aligned_s"] == pytest.approx(12.32)
    positions = c["windows"] + c["dropped_gap"] + c["empty_gap"]
    assert positions == (6 if partition_s is None else 4)
    assert c["aligned_s"] == pytest.approx(
        positions * 2.0 + c["window_tail_s"] + c["partition_tail_s"])
    assert c["window_tail_s"] == pytest.approx(0.32 if partition_s is None else 2.0)


@given(st.floats(0.5, 9.0), st.integers(4, 30), st.sampled_from([0.2, 0.5, 1.0]))
@settings(max_examples=25, deadline=None)
def test_no_kept_window_holds_a_grid_point_inside_a_gap(start_s, tenths, hop_s):
    # a wheel hole of 0.4-3 s (>= 4 wheel steps: a gap): no kept window holds an instant of
    # it, and every window position is kept, dropped for the gap or counted as empty
    a = round(start_s, 1)
    b = a + tenths / 10.0
    run = _plain_run(hole=(a, b))
    config = WindowConfig(window_s=1.0, hop_s=hop_s)
    ws = make_windows([run], "all", config)
    n, hop = config.n_samples, config.hop_samples
    total = int(round(12.0 * config.rate_hz)) + 1
    c = ws.counts
    assert len(ws) + c["dropped_gap"] + c["empty_gap"] == (total - n) // hop + 1
    assert c["dropped_gap"] >= 1 and np.isfinite(ws.X).all()
    t = ws.t_start_s[:, None] + np.arange(n)[None, :] / config.rate_hz
    assert not ((t > a + 1e-9) & (t < b - 1e-9)).any()


@pytest.mark.parametrize("signals", ["wheels", ["vel_l", "vel_mean"], ["cur_sum"]])
def test_a_wheel_stream_without_its_currents_is_a_typed_error_naming_the_run(signals):
    # a hand-built Run whose wheels stream holds only the speeds ended in a bare KeyError
    # "['cur_l', 'cur_r', 'vel_mean', ...] not in index" from the windowing; the derived
    # channels (vel_mean included) are made from all four wheel channels
    tw = np.arange(201) / 10.0
    wheels = pd.DataFrame({TIME: tw, "vel_l": 0.5, "vel_r": 0.6})
    run = Run(run_id="t/ICE/07", dataset="t", terrain="ICE", streams={"wheels": wheels},
              source="hand-built")
    with pytest.raises(MissingColumnError, match=r"run t/ICE/07: stream 'wheels' lacks "
                                                 r"columns \['cur_l', 'cur_r'\]") as err:
        make_windows([run], signals, WindowConfig(window_s=2.0))
    assert err.value.column == "cur_l" and err.value.path == "hand-built"
    # the speeds alone suffice for the raw speed channels
    ws = make_windows([run], ["vel_l", "vel_r"], WindowConfig(window_s=2.0))
    assert len(ws) == 10
    np.testing.assert_allclose(ws.X[:, 1], 0.6)
