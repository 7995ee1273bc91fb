"""``terrain stream`` on measured-layout files, for a wheel-only and an IMU + wheel model."""

from __future__ import annotations

import pandas as pd
import pytest

from terrain.cli import main
from terrain.serving.pyfunc import save_model
from terrain.serving import load_stream_model

COLUMNS_TAIL = ["target_slip_traction", "target_slip_braking", "target_slip_steady",
                "window_age_s", "flags"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, borealtc_runs, train_runs):
    """An unseen SNOW run written back to the CSV layout: <root>/SNOW/{imu,pro}_07.csv."""
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.terrain == "SNOW" and r.has_imu
               and r.run_id not in seen and r.duration_s > 30)
    folder = tmp_path_factory.mktemp("runs") / "SNOW"
    folder.mkdir()
    w = run.streams["wheels"].rename(columns={"t_s": "time", "vel_l": "velL", "vel_r": "velR",
                                              "cur_l": "curL", "cur_r": "curR"})
    w[["time", "curL", "curR", "velL", "velR"]].to_csv(folder / "pro_07.csv", index=False)
    run.streams["imu"].rename(columns={"t_s": "time"}).to_csv(folder / "imu_07.csv",
                                                              index=False)
    return folder


def _saved(model, path):
    save_model(path, model.pipeline, model.channels, model.window, list(model.classes),
               {"dataset": "borealtc-test"})
    loaded = load_stream_model(path)
    assert loaded.channels == model.channels and loaded.classes == model.classes
    return path


@pytest.mark.parametrize("kind", ["wheel_model", "all_model"])
def test_stream_writes_one_decision_per_hop_with_the_issue_columns(kind, request, run_dir,
                                                                   tmp_path, capsys,
                                                                   monkeypatch):
    monkeypatch.chdir(tmp_path)
    model = request.getfixturevalue(kind)
    model_dir = _saved(model, tmp_path / "model")
    out = tmp_path / "decisions.csv"
    assert main(["stream", "--model", str(model_dir), str(run_dir), "--out", str(out),
                 "--hop-s", "1.0"]) == 0
    frame = pd.read_csv(out, keep_default_na=False)
    assert list(frame.columns) == (["t_s", "terrain", "confidence"]
                                   + [f"proba_{c}" for c in model.classes] + COLUMNS_TAIL)
    assert len(frame) > 20 and (frame["t_s"].diff().dropna().round(9) == 1.0).all()
    assert set(frame["terrain"]) <= set(model.classes)
    printed = capsys.readouterr().out
    assert "decisions every 1.0 s" in printed and "SNOW" in printed


def test_stream_errors_are_typed_messages(run_dir, tmp_path, capsys, all_model, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["stream", "--model", str(tmp_path), str(run_dir), "--out",
                 str(tmp_path / "d.csv")]) == 2
    assert "not a terrain model directory" in capsys.readouterr().err
    wheel_only = tmp_path / "runs" / "SNOW"
    wheel_only.mkdir(parents=True)
    (wheel_only / "pro_07.csv").write_text((run_dir / "pro_07.csv").read_text())
    model_dir = _saved(all_model, tmp_path / "model")
    assert main(["stream", "--model", str(model_dir), str(wheel_only), "--out",
                 str(tmp_path / "d.csv")]) == 2
    assert "needs stream(s) ['imu']" in capsys.readouterr().err
