"""Boundaries of the served models' window counts (srv21): a run exactly one window long,
one sample short of it, and the windows a request's last samples complete."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig
from terrain.errors import DataFormatError, TimestampError
from terrain.run import Run
from terrain.serving.pyfunc import predict_windows


class _Proba:
    """A fitted stand-in classifier: the same probabilities for every window."""

    classes_ = np.array(["A", "B"])

    def predict_proba(self, X):
        return np.tile([0.3, 0.7], (len(X), 1))


class _WindowingModel:
    """``terrain predict``'s model as MLflow loads it: the real windowing of
    :func:`predict_windows` over the stand-in classifier."""

    def __init__(self, config: WindowConfig) -> None:
        self.config = config

    def predict(self, samples):
        return predict_windows(_Proba(), samples, ["vel_l", "vel_r"], self.config, ["A", "B"])


class _Recorder:
    """Stand-in of :func:`terrain.tracking.tracked_run` keeping the metrics logged."""

    def __init__(self) -> None:
        self.metrics: dict = {}

    def __call__(self, *args, **kwargs):
        return self

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def log_metrics(self, metrics, step=None):
        self.metrics.update(metrics)

    def log_table(self, *args, **kwargs):
        pass

    def describe(self):
        return "run"


def _wheel_run(n: int, rate_hz: float) -> Run:
    t = np.arange(n) / rate_hz
    wheels = pd.DataFrame({"t_s": t, "vel_l": 0.5 + 0 * t, "vel_r": 0.6 + 0 * t,
                           "cur_l": 5.0 + 0 * t, "cur_r": 6.0 + 0 * t})
    return Run(run_id="test/ASPHALT/00", dataset="test", terrain=None,
               streams={"wheels": wheels}, source="in-memory test run")


def _predict(monkeypatch, tmp_path, config: WindowConfig, n: int):
    import pipelines.predict as predict
    from terrain.cli import main

    meta = {"window_s": config.window_s, "rate_hz": config.rate_hz,
            "channels": ["vel_l", "vel_r"]}
    monkeypatch.setattr(predict, "_load",
                        lambda uri, progress: (_WindowingModel(config), meta))
    monkeypatch.setattr(predict, "read_runs_path",
                        lambda *a, **k: [_wheel_run(n, config.rate_hz)])
    recorder = _Recorder()
    monkeypatch.setattr(predict, "tracked_run", recorder)
    (tmp_path / "runs").mkdir(exist_ok=True)
    code = main(["predict", "--model", str(tmp_path), str(tmp_path / "runs"), "--out",
                 str(tmp_path / "p.csv"), "--no-progress"])
    return code, recorder.metrics


@pytest.mark.parametrize("window_s, rate_hz", [(0.25, 50.0), (2.0, 50.0), (0.1 * 7, 10.0),
                                               (1.0, 6.5)])
def test_predict_counts_a_run_of_exactly_one_window_as_used(monkeypatch, tmp_path, capsys,
                                                            window_s, rate_hz):
    """A run of exactly ``n_samples`` aligned samples gives one window: it is used, not
    too short. ``len / rate < window_s`` called it too short where ``window_s * rate``
    rounds down to the window's samples (0.25 s at 50 Hz: 12.5 -> 12 samples, 0.24 s;
    0.1 * 7 s at 10 Hz: 7.000000000000001 -> 7): "1 windows from 0 of 1 runs"."""
    config = WindowConfig(window_s=window_s, rate_hz=rate_hz)
    code, metrics = _predict(monkeypatch, tmp_path, config, config.n_samples)
    out = capsys.readouterr().out
    assert code == 0
    assert metrics["n_windows"] == 1
    assert metrics["n_runs_used"] == 1 and metrics["input_runs_too_short"] == 0, out
    assert "1 windows from 1 of 1 runs" in out


@pytest.mark.parametrize("window_s, rate_hz", [(0.25, 50.0), (2.0, 50.0), (0.35, 50.0)])
def test_predict_counts_a_run_one_sample_short_of_a_window_as_too_short(
        monkeypatch, tmp_path, capsys, window_s, rate_hz):
    """One aligned sample fewer than a window: no window, and the run is too short."""
    config = WindowConfig(window_s=window_s, rate_hz=rate_hz)
    code, _ = _predict(monkeypatch, tmp_path, config, config.n_samples - 1)
    captured = capsys.readouterr()
    assert code == 2
    assert "1 run(s) too short" in captured.out, captured.out
    assert "no window to predict" in captured.err


def _aligned(t: np.ndarray) -> pd.DataFrame:
    """Aligned wheel samples of one run at the stamps ``t``."""
    return pd.DataFrame({"run": "r1", "t_s": t, "vel_l": 0.5 + 0 * t, "vel_r": 0.6 + 0 * t})


def _windows(samples: pd.DataFrame, rate_hz: float = 50.0) -> pd.DataFrame:
    return predict_windows(_Proba(), samples, ["vel_l", "vel_r"],
                           WindowConfig(window_s=2.0, rate_hz=rate_hz), ["A", "B"])


@pytest.mark.parametrize("rate_hz", [49.502, 50.498, 49.6, 50.4])
def test_a_sample_rate_within_one_percent_of_the_models_is_taken(rate_hz):
    """Within 1 % of the model's 50 Hz, as the docstring promises ("a median sample rate
    more than 1 % off"): 49.502 Hz (0.996 % slow) was refused, its step being 1.006 %
    longer than the model's period (the rule compared steps, not rates)."""
    assert len(_windows(_aligned(np.arange(300) / rate_hz))) > 0


@pytest.mark.parametrize("rate_hz", [50.503, 49.497, 50.6, 49.4])
def test_a_sample_rate_more_than_one_percent_off_the_models_is_refused(rate_hz):
    """More than 1 % off the model's 50 Hz: 50.503 Hz (1.006 % fast) was taken, its step
    only 0.996 % shorter than the model's period."""
    with pytest.raises(DataFormatError, match=rf"samples at {rate_hz:.3f} Hz; the model "
                                              r"expects 50\.0 Hz"):
        _windows(_aligned(np.arange(300) / rate_hz))


def test_a_step_of_exactly_one_and_a_half_periods_is_no_hole():
    """A step longer than 1.5 sample periods is a hole (refused); one of exactly 1.5 periods
    is not (8 Hz: 0.1875 s, exact in binary), one a period longer is."""
    steps = np.full(40, 0.125)
    steps[20] = 0.1875
    t = np.r_[0.0, np.cumsum(steps)]
    assert np.diff(t)[20] * 8.0 == 1.5
    assert len(_windows(_aligned(t), rate_hz=8.0)) == 2
    steps[20] = 0.25
    with pytest.raises(TimestampError, match="a step of 0.25 s, 1 step"):
        _windows(_aligned(np.r_[0.0, np.cumsum(steps)]), rate_hz=8.0)
