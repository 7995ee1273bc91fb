"""Runs looked up by id are given each once: a repeated id kept the last run without a
word, and the windows of the other were scored on it (est19's left-alone, stop 92)."""

from __future__ import annotations

import pandas as pd
import pytest

from features.slip_features import slip_targets
from features.windows import WindowConfig, make_windows
from terrain.errors import ConfigError
from terrain.run import Run, runs_by_id
from terrain.slip.evaluation import observer_window_slip, odometry_errors


def _run(rid, shift=0.0):
    t = pd.Series([0.0, 0.5, 1.0, 1.5, 2.0, 2.5])
    wheels = pd.DataFrame({"t_s": t, "vel_l": 0.5 + shift, "vel_r": 0.5, "cur_l": 1.0,
                           "cur_r": 1.0})
    return Run(rid, "sim", "ICE", {"wheels": wheels})


def test_runs_by_id_keys_each_run_and_refuses_a_repeated_id():
    a, b = _run("a"), _run("b")
    assert runs_by_id([a, b], "f") == {"a": a, "b": b}
    assert runs_by_id(iter([a]), "f") == {"a": a}
    with pytest.raises(ConfigError, match=r"f: run id\(s\) \['a'\] given more than once"):
        runs_by_id([a, b, _run("a", 0.1)], "f")


def test_the_slip_scorers_refuse_a_run_given_twice():
    runs = [_run("a"), _run("a", 0.1)]
    meta = pd.DataFrame({"run_id": ["a"], "t_start_s": [0.0], "t_end_s": [2.0]})
    with pytest.raises(ConfigError, match="observer_window_slip: run id"):
        observer_window_slip(runs, meta, 0.57)
    with pytest.raises(ConfigError, match="odometry_errors: run id"):
        odometry_errors(runs, meta, [[0.0, 0.0, 1.0]], 0.57, ["a"])
    ws = make_windows(runs[:1], ("vel_l", "vel_r"), WindowConfig(window_s=2.0, rate_hz=2.0))
    with pytest.raises(ConfigError, match="slip_targets: run id"):
        slip_targets(runs, ws, 0.57)
