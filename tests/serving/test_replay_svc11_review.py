"""Review svc11: what ``terrain stream`` tells a user of a replay (RunReplay.summary)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from terrain.run import Run
from terrain.serving.decisions import Decision, decisions_frame
from terrain.serving.replay import RunReplay


def _replay(refused: dict) -> RunReplay:
    run = Run("t/ASPHALT/00", "t", "ASPHALT",
              {"wheels": pd.DataFrame({"t_s": [0.0, 1.0], "vel_l": [0.1, 0.1]})})
    d = Decision(2.0, "ASPHALT", 0.9, np.array([0.9, 0.1]), 0.1, -0.1, 0.05, 0.0, "")
    frame = decisions_frame([d], ("ASPHALT", "GRASS"))
    return RunReplay(run, frame, 0, 10.0, 2.0, 0.5, 60.0, ("wheels",), refused, {}, 0, 2.0,
                     10.0)


def test_summary_counts_the_samples_the_service_refused():
    """The refused samples (counted per stream and reason by the service) reach the user
    of ``terrain stream``: a re-sent sample is refused without a flag, so the summary was
    the only place it could show; it said nothing of 7 duplicates and 3 non-finite
    samples."""
    text = _replay({("wheels", "duplicate"): 7, ("imu", "non_finite"): 3}).summary("d.csv")
    first = text.splitlines()[0]
    assert "refused 3 samples of stream imu (non_finite), 7 of stream wheels (duplicate)" \
        in first
    assert first.endswith("written to d.csv")
    one = _replay({("wheels", "implausible_value"): 1}).summary("d.csv")
    assert "; refused 1 sample of stream wheels (implausible_value); written" in one
    # nothing refused: no word of it
    assert "refused" not in _replay({}).summary("d.csv")


def test_summary_of_no_decision_has_no_label_share():
    """A replay without decisions gives no share decided as the run's label (the mean of
    no decision would print as nan), and says 0 decisions."""
    from dataclasses import replace

    one = _replay({})
    assert one.summary("d.csv").splitlines()[1] == \
        "  decided ASPHALT (the folder's label) in 1.000 of the decisions"
    empty = replace(one, frame=one.frame.iloc[:0])
    lines = empty.summary("d.csv").splitlines()
    assert len(lines) == 1 and lines[0].startswith("t/ASPHALT/00: 0 decisions every 0.5 s")


def _wz_service():
    """IMU and wheels at 8 Hz, 2 s windows every 0.5 s (the deterministic yaw-rate model
    of ``test_stream_scores``)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).parent))
    from test_stream_scores import _WzClassifier

    from features.windows import WindowConfig
    from terrain.serving import (CataloguePeakTargets, StreamConfig, StreamModel,
                                 StreamService)
    classes = tuple(_WzClassifier.classes_)
    model = StreamModel(_WzClassifier(), ("vel_l", "wz"),
                        WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=8.0), classes)
    return StreamService(model, CataloguePeakTargets(classes, 0.5),
                         StreamConfig(hop_s=0.5, min_confidence=0.5))


def _two_stream_run() -> Run:
    """12 s of IMU and wheels at 8 Hz (binary-exact stamps), every channel moving."""
    from terrain.run import IMU_CHANNELS
    t = np.arange(96) * 0.125
    imu = {"t_s": t, **{c: 0.01 * np.sin(7.0 * t + i) for i, c in enumerate(IMU_CHANNELS)}}
    imu["az"] = imu["az"] + 9.81
    imu["wz"] = imu["wz"] + 0.3 * (t > 6)
    wheels = {"t_s": t, "vel_l": 0.25 + 0.01 * np.cos(5 * t), "vel_r": 0.25 + 0.01 * np.sin(5 * t),
              "cur_l": 1 + 0.01 * np.sin(3 * t), "cur_r": 1 - 0.01 * np.sin(3 * t)}
    return Run("t/SNOW/00", "t", "SNOW", {"imu": pd.DataFrame(imu),
                                          "wheels": pd.DataFrame(wheels)})


def test_replay_run_reads_the_channels_by_name_in_any_column_order():
    """``replay_run`` pushes each chunk as ``{channel: values}``: a stream frame whose
    columns come in another order gives the same decisions (its docstring said the order
    must match the service's), and a frame lacking a channel is refused naming it."""
    import pytest

    from terrain.errors import MissingColumnError
    from terrain.serving.replay import replay_run

    run = _two_stream_run()
    want = decisions_frame(replay_run(_wz_service(), run), ("ASPHALT", "ICE", "SNOW"))
    assert len(want) > 10
    wheels = run.streams["wheels"]
    turned = Run(run.run_id, run.dataset, run.terrain,
                 {"imu": run.streams["imu"], "wheels": wheels[["t_s", *wheels.columns[:0:-1]]]})
    assert list(turned.streams["wheels"].columns) == ["t_s", "cur_r", "cur_l", "vel_r", "vel_l"]
    got = decisions_frame(replay_run(_wz_service(), turned), ("ASPHALT", "ICE", "SNOW"))
    pd.testing.assert_frame_equal(got, want)
    lacking = Run(run.run_id, run.dataset, run.terrain,
                  {"imu": run.streams["imu"], "wheels": wheels.drop(columns="cur_r")})
    with pytest.raises(MissingColumnError, match=r"lacks channel\(s\) \['cur_r'\]"):
        replay_run(_wz_service(), lacking)
