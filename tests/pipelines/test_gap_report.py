"""The input report tells the truth about timestamp gaps and the windows they cost, and the
readers' timestamp errors print plain numbers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig, make_windows, window_frame
from terrain.errors import TimestampError
from terrain.io.measured import read_stream_csv
from terrain.io.report import input_report, merged_gaps
from terrain.run import Run
from terrain.serving.pyfunc import predict_windows

CLASSES = ("A", "B")


class _Constant:
    """Fitted stand-in classifier: probability 0.75 for class A on every window."""

    classes_ = np.array(CLASSES)

    def predict_proba(self, X):
        assert np.isfinite(X).all()          # never given a window holding a gap
        return np.tile([0.75, 0.25], (len(X), 1))


def _run(gaps: dict) -> Run:
    return Run("runs/X/00", "runs", None, {}, meta={"gaps": gaps})


def test_one_hole_seen_by_every_stream_is_one_gap():
    gaps = {"imu": [(10.0, 1010.0)], "wheels": [(9.95, 1010.05)]}
    assert merged_gaps(gaps) == [(9.95, 1010.05)]
    report = input_report([_run(gaps)])
    assert report.metrics()["input_gaps"] == 1
    assert report.metrics()["input_gap_s"] == pytest.approx(1000.1)
    assert "1 timestamp gap(s) (1000.1 s) in runs/X/00" in report.text()


def test_several_gaps_are_listed_with_their_total():
    gaps = {"imu": [(10.0, 13.0), (500.0, 1500.0)], "wheels": [(12.0, 14.0)]}
    assert merged_gaps(gaps) == [(10.0, 14.0), (500.0, 1500.0)]
    text = input_report([_run(gaps)]).text()
    assert "2 timestamp gap(s) (4.0 s, 1000.0 s; 1004.0 s in all) in runs/X/00" in text


def test_a_corrupt_timestamp_gap_prints_as_a_short_number():
    # a wheel file whose first timestamp read -1e300 printed a 300-digit gap (CLI fuzz)
    text = input_report([_run({"wheels": [(-1e300, 0.0)]})]).text()
    assert "1 timestamp gap(s) (1e+300 s) in runs/X/00" in text and len(text) < 200


def test_windows_inside_a_hole_of_every_stream_are_not_counted_as_dropped():
    """Planted: 2 s windows at 10 Hz over 0-1040 s, every channel NaN strictly inside
    (20 s, 1020 s). The window [20, 22) holds data and a gap: dropped. The 499 windows from
    22 s to 1020 s hold no sample at all: empty, not dropped."""
    t = np.round(np.arange(0.0, 1040.0, 0.1), 6)
    hole = (t > 20.0) & (t < 1020.0)
    values = {c: np.where(hole, np.nan, v) for c, v in
              (("vel_l", 0.5), ("vel_r", 0.6), ("cur_l", 5.0), ("cur_r", 7.0))}
    samples = pd.DataFrame({"run": "r", "t_s": t, **values})
    config = WindowConfig(window_s=2.0, rate_hz=10.0)
    out = predict_windows(_Constant(), samples, ["vel_l", "vel_r", "cur_l", "cur_r"], config,
                          CLASSES)
    assert out.attrs["dropped_windows"] == 1 and out.attrs["empty_windows"] == 499
    assert len(out) == 10 + 10  # [0, 20) and [1020, 1040)
    assert len(out) + 1 + 499 == 520  # every window position accounted for once
    report = input_report([_run({"imu": [(20.0, 1020.0)]})],
                          {"per_run": {"runs/X/00": {"windows": len(out), "dropped_gap": 1,
                                                     "dropped_unsteady": 0,
                                                     "empty_gap": 499}}}, 2.0)
    text = report.text()
    assert "dropped windows: 1 spanning a gap" in text
    assert "499 window position(s) wholly inside a gap of every stream: no data there, not " \
           "counted as dropped" in text
    assert report.metrics()["input_windows_dropped_gap"] == 1


def test_window_frame_counts_the_hole_as_cv_and_train_report_it():
    """The same planted hole through :func:`features.windows.window_frame`, the windowing of
    ``terrain cv`` / ``train``: one window of data dropped, 499 empty positions apart."""
    t = np.round(np.arange(0.0, 1040.0, 0.1), 6)
    hole = (t > 20.0) & (t < 1020.0)
    frame = pd.DataFrame({"t_s": t, "vel_l": np.where(hole, np.nan, 0.5),
                          "cur_l": np.where(hole, np.nan, 5.0)})
    X, _, _, _, counts = window_frame(frame, ["vel_l", "cur_l"],
                                      WindowConfig(window_s=2.0, rate_hz=10.0))
    assert len(X) == 20 and counts["dropped_gap"] == 1 and counts["empty_gap"] == 499


def test_partition_tails_and_runs_without_a_full_partition_are_reported(make_run):
    """The papers' protocol windows whole 5 s partitions only: the rest of each run is
    reported, and a run longer than a window but shorter than a partition is too short."""
    t = np.round(np.arange(0.0, 12.0, 0.1), 6)
    wheels = pd.DataFrame({"t_s": t, "vel_l": 0.5, "vel_r": 0.6, "cur_l": 5.0, "cur_r": 6.0})
    runs = [make_run({"wheels": wheels}, "t/ICE/00", "ICE"),
            make_run({"wheels": wheels[t < 3.0]}, "t/ICE/01", "ICE")]
    ws = make_windows(runs, "wheels", WindowConfig(window_s=1.7, hop_s=0.1, rate_hz=10.0,
                                                   partition_s=5.0))
    report = input_report(runs, ws.counts, 1.7)
    text = report.text()
    assert ("not windowed: 5.0 s of run tails after the last full partition (partition "
            "protocol) in t/ICE/00, t/ICE/01") in text
    assert "1 run(s) too short (shorter than one 5 s partition): t/ICE/01" in text
    assert report.metrics()["input_partition_tail_s"] == pytest.approx(2.0 + 3.0)
    assert list(report.table["partition_tail_s"]) == pytest.approx([2.0, 3.0])


@pytest.mark.parametrize("times, words", [
    ([0.0, 0.1, 0.2, 0.2, 0.3], "duplicated timestamp 0.2 after 0.2"),
    ([0.0, 0.1, 0.2, 0.15, 0.3], "decreasing timestamp 0.15 after 0.2"),
])
def test_timestamp_errors_print_plain_numbers(tmp_path, times, words):
    path = tmp_path / "pro_00.csv"
    n = len(times)
    pd.DataFrame({"time": times, "velL": [0.5] * n, "velR": [0.5] * n, "curL": [5.0] * n,
                  "curR": [5.0] * n}).to_csv(path, index=False)
    with pytest.raises(TimestampError) as exc:
        read_stream_csv(path, "pro")
    assert words in str(exc.value) and "np." not in str(exc.value)
    assert exc.value.line == 5 and exc.value.column == "time"


def _samples(t):
    n = len(t)
    return pd.DataFrame({"run": "r", "t_s": t, "vel_l": [0.5] * n, "vel_r": [0.6] * n,
                         "cur_l": [5.0] * n, "cur_r": [7.0] * n})


@pytest.mark.parametrize("where, value", [(30, np.nan), (59, np.inf)])
def test_served_model_refuses_a_non_finite_timestamp(where, value):
    from terrain.errors import NonFiniteError
    t = np.round(np.arange(0.0, 6.0, 0.1), 6)
    t[where] = value
    with pytest.raises(NonFiniteError) as exc:
        predict_windows(_Constant(), _samples(t), ["vel_l", "vel_r", "cur_l", "cur_r"],
                        WindowConfig(window_s=2.0, rate_hz=10.0), CLASSES)
    assert exc.value.row == where and "run r" in str(exc.value)


def test_served_model_refuses_a_time_hole_without_rows():
    # rows cut out of the uniform clock: a window by row would span 0.0-101.9 s as one
    # 2 s window (a gap is NaN rows on the clock, as align_streams gives)
    t = np.round(np.r_[np.arange(0.0, 5.0, 0.1), 100.0 + np.arange(0.0, 5.0, 0.1)], 6)
    with pytest.raises(TimestampError) as exc:
        predict_windows(_Constant(), _samples(t), ["vel_l", "vel_r", "cur_l", "cur_r"],
                        WindowConfig(window_s=2.0, rate_hz=10.0), CLASSES)
    assert exc.value.row == 50 and "1 step(s) longer than 1.5 sample periods" in str(exc.value)


def test_served_model_refuses_samples_without_a_run():
    # a row whose run is missing (JSON null through `mlflow models serve`, which passes it
    # on as NaN) was left out by the groupby without a word: all-null runs gave 0 windows
    from terrain.errors import DataFormatError
    samples = _samples(np.round(np.arange(0.0, 6.0, 0.1), 6)).astype({"run": object})
    samples.loc[40:, "run"] = None
    with pytest.raises(DataFormatError) as exc:
        predict_windows(_Constant(), samples, ["vel_l", "vel_r", "cur_l", "cur_r"],
                        WindowConfig(window_s=2.0, rate_hz=10.0), CLASSES)
    assert exc.value.column == "run" and exc.value.row == 40
    assert "20 sample(s) without a run" in str(exc.value)


def test_served_model_counts_the_run_tail_after_its_last_window():
    # 6.5 s at 10 Hz (65 samples) in 2 s windows: 3 windows, 0.5 s after the last one that
    # terrain predict's input report did not mention
    t = np.round(np.arange(0.0, 6.5, 0.1), 6)
    out = predict_windows(_Constant(), _samples(t), ["vel_l", "vel_r", "cur_l", "cur_r"],
                          WindowConfig(window_s=2.0, rate_hz=10.0), CLASSES)
    assert len(out) == 3 and out.attrs["window_tail_s"] == pytest.approx(0.5)


def test_served_model_counts_the_time_between_windows_of_a_long_hop():
    # 10 s at 10 Hz in 2 s windows every 3 s: windows at 0, 3, 6 s (the next would end at
    # 11 s), 1 s between each pair and 2 s after the last; the 2 s between them were in no
    # count of terrain predict's input report
    t = np.round(np.arange(0.0, 10.0, 0.1), 6)
    out = predict_windows(_Constant(), _samples(t), ["vel_l", "vel_r", "cur_l", "cur_r"],
                          WindowConfig(window_s=2.0, hop_s=3.0, rate_hz=10.0), CLASSES)
    assert len(out) == 3
    assert out.attrs["between_windows_s"] == pytest.approx(2.0)
    assert out.attrs["window_tail_s"] == pytest.approx(2.0)
