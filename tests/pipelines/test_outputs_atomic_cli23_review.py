"""What a failed command leaves behind: its output files are whole or untouched
(pipelines/predict.py, stream.py, cv.py, train.py, compare.py); failures are simulated with
stand-ins (a disk full half-way through a CSV, a model folder that cannot be written)."""

from __future__ import annotations

import errno
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from cli_helpers import RecordingRun, exit_code

PREVIOUS = "run,predicted\nold,ICE\n"


def _disk_full_half_way(monkeypatch):
    """``DataFrame.to_csv`` to a path writes its first line, then fails as a full disk."""
    real = pd.DataFrame.to_csv

    def to_csv(frame, path=None, *args, **kwargs):
        if path is None or not hasattr(path, "__fspath__") and not isinstance(path, str):
            return real(frame, path, *args, **kwargs)
        text = real(frame, None, *args, **kwargs)
        with open(path, "w") as handle:
            handle.write(text.splitlines(keepends=True)[0])
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(pd.DataFrame, "to_csv", to_csv)


def _left(folder, out):
    """The files of ``folder`` (``out``'s content apart)."""
    return sorted(p.name for p in folder.iterdir())


class _WindowModel:
    def predict(self, samples):
        n = max(len(samples) // 200, 1)
        return pd.DataFrame({"t_start_s": 2.0 * np.arange(n), "t_end_s": 2.0 * np.arange(n) + 2,
                             "predicted": ["ICE"] * n})


@pytest.mark.parametrize("previous", [True, False])
def test_predict_failing_half_way_through_the_csv_leaves_no_partial_file(
        tmp_path, monkeypatch, write_run, synth_imu, synth_pro, previous):
    """A disk full half-way through the predictions: the earlier predictions file stays as
    it was (it was cut to its header line), or no file is left (a header line alone was left,
    read later as a run without any window); no temporary file is left either."""
    import pipelines.predict as predict

    meta = {"window_s": 2.0, "rate_hz": 100.0,
            "channels": ["vel_l", "vel_r", "cur_l", "cur_r", "wx", "wy", "wz", "ax", "ay", "az"]}
    monkeypatch.setattr(predict, "_load", lambda uri, progress: (_WindowModel(), meta))
    monkeypatch.setattr(predict, "tracked_run", RecordingRun())
    runs = tmp_path / "runs"
    write_run(runs, "ICE", "00", synth_imu(5.0), synth_pro(5.0))
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / "p.csv"
    if previous:
        out.write_text(PREVIOUS)
    _disk_full_half_way(monkeypatch)
    assert exit_code(["predict", "--model", str(tmp_path), str(runs), "--out", str(out),
                      "--no-progress"]) != 0
    assert _left(folder, out) == (["p.csv"] if previous else [])
    if previous:
        assert out.read_text() == PREVIOUS


def _stream_stand_ins(monkeypatch):
    import pipelines.stream as stream

    model = SimpleNamespace(classes=("ICE",), metadata={}, channels=("wz",),
                            window=SimpleNamespace(rate_hz=100.0))
    replay = SimpleNamespace(frame=pd.DataFrame({"t_s": [2.0, 2.5], "terrain": ["ICE"] * 2}),
                             input_report=lambda: SimpleNamespace(text=lambda: "report"),
                             check=lambda where: None, summary=lambda out: f"-> {out}")
    monkeypatch.setattr(stream, "load_stream_model", lambda path: model)
    monkeypatch.setattr(stream, "read_folder_run", lambda folder, index: SimpleNamespace(
        vehicle="husky", run_id="r"))
    monkeypatch.setattr(stream, "TableTargets", lambda *a: None)
    monkeypatch.setattr(stream, "StreamService", lambda *a: None)
    monkeypatch.setattr(stream, "replay_recorded", lambda service, run: replay)
    monkeypatch.setattr(stream, "other_vehicle_note", lambda *a: None)
    monkeypatch.setattr(stream, "imu_rate_note", lambda *a: None)


@pytest.mark.parametrize("previous", [True, False])
def test_stream_failing_half_way_through_the_csv_leaves_no_partial_file(
        tmp_path, monkeypatch, previous):
    """As ``terrain predict``: ``terrain stream --out`` is written whole or not at all."""
    _stream_stand_ins(monkeypatch)
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / "d.csv"
    if previous:
        out.write_text(PREVIOUS)
    _disk_full_half_way(monkeypatch)
    assert exit_code(["stream", "--model", str(tmp_path), str(tmp_path), "--out",
                      str(out)]) != 0
    assert _left(folder, out) == (["d.csv"] if previous else [])
    if previous:
        assert out.read_text() == PREVIOUS


def test_stream_writes_the_decisions_whole(tmp_path, monkeypatch, capsys):
    _stream_stand_ins(monkeypatch)
    out = tmp_path / "new" / "d.csv"
    assert exit_code(["stream", "--model", str(tmp_path), str(tmp_path), "--out",
                      str(out)]) == 0
    assert pd.read_csv(out)["t_s"].tolist() == [2.0, 2.5]
    assert sorted(p.name for p in out.parent.iterdir()) == ["d.csv"]


def test_whole_file_keeps_the_mode_and_writes_through_a_link(tmp_path):
    """A file replaced whole keeps its permission bits; a link given as the output is
    written through (the file it names), as ``open`` wrote it, not replaced by a file."""
    import os

    from terrain.io.jsonfile import whole_file

    target = tmp_path / "target.csv"
    target.write_text(PREVIOUS)
    os.chmod(target, 0o640)
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    with whole_file(link) as tmp:
        tmp.write_text("new\n")
    assert link.is_symlink() and target.read_text() == "new\n"
    assert target.stat().st_mode & 0o777 == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "target.csv"]
    with pytest.raises(KeyboardInterrupt), whole_file(target) as tmp:
        tmp.write_text("half")
        raise KeyboardInterrupt
    assert target.read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "target.csv"]


@pytest.mark.parametrize("previous", [True, False])
def test_cv_failing_half_way_through_the_json_leaves_no_partial_file(
        tmp_path, monkeypatch, previous):
    """``terrain cv --json`` cut short by a full disk: no JSON file cut short (which ``json``
    readers refuse) and the report of an earlier run kept."""
    from pathlib import Path

    from test_pipe3_review import _cv_result

    import pipelines.cv as cv

    monkeypatch.setattr(cv, "load_dataset", lambda name: [])
    monkeypatch.setattr(cv, "run_cv", lambda config, runs, progress: _cv_result(config))
    monkeypatch.setattr(cv, "input_report", lambda *a: SimpleNamespace(
        text=lambda: "", metrics=lambda: {}, table=pd.DataFrame()))
    monkeypatch.setattr(cv, "plot_confusion", lambda *a: None)
    monkeypatch.setattr(cv, "tracked_run", RecordingRun())
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / "cv.json"
    if previous:
        out.write_text('{"old": 1}\n')

    def write_text(path, text, *args, **kwargs):
        with open(path, "w") as handle:
            handle.write(text[:10])
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(Path, "write_text", write_text)
    assert exit_code(["cv", "--seeds", "0", "--json", str(out), "--no-progress"]) != 0
    assert _left(folder, out) == (["cv.json"] if previous else [])
    if previous:
        assert out.read_text() == '{"old": 1}\n'
