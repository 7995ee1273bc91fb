"""What ``terrain slip-fit`` leaves in ``--out`` when it fails half-way: the earlier run's
outputs whole, not a new ``summary.json`` beside the earlier tables and figures; and no
table of an earlier run beside a new report (tiny simulated grid, MLflow stood in for, a
failure simulated with monkeypatch)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from cli_helpers import RecordingRun

import pipelines.slip_fit as slip_fit
from terrain.cli import main
from terrain.io.jsonfile import staged_outputs


def _slip_fit(tmp_path: Path) -> int:
    return main(["slip-fit", "--terrains", "ICE", "--scenarios", "straight_accel",
                 "--train-seeds", "0", "--test-seeds", "100", "--duration-s", "2",
                 "--orchard-duration-s", "1", "--no-loto", "--no-register",
                 "--out", str(tmp_path / "o"), "--cache-dir", str(tmp_path / "c")])


def _listing(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.mark.slow
def test_a_failed_rerun_leaves_the_earlier_outputs_whole(tmp_path, monkeypatch):
    monkeypatch.setattr(slip_fit, "tracked_run", RecordingRun())
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "measured_checks.csv").write_text("of an earlier --measured run\n")
    assert _slip_fit(tmp_path) == 0
    out = tmp_path / "o"
    assert sorted(_listing(out)) == ["odometry.csv", "odometry.png", "slip_errors.csv",
                                     "slip_errors.png", "std_calibration.csv",
                                     "summary.json"]
    before = _listing(out)
    (out / "summary.json").write_text("{}\n")     # marks the earlier run's files
    before["summary.json"] = b"{}\n"

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(slip_fit, "odometry_figure", full)
    assert _slip_fit(tmp_path) != 0
    assert _listing(out) == before


def test_staged_outputs_is_all_or_nothing(tmp_path, monkeypatch):
    out = tmp_path / "o"
    out.mkdir()
    (out / "a.csv").write_text("earlier\n")
    (out / "b.png").write_text("earlier figure\n")
    (out / "notes.txt").write_text("the user's\n")
    with pytest.raises(KeyboardInterrupt):
        with staged_outputs(out, ("*.csv", "*.png")) as stage:
            (stage / "a.csv").write_text("new\n")
            raise KeyboardInterrupt
    assert _listing(out) == {"a.csv": b"earlier\n", "b.png": b"earlier figure\n",
                             "notes.txt": b"the user's\n"}
    moved = []
    real = os.replace
    monkeypatch.setattr(os, "replace", lambda a, b: (moved.append(Path(b).name), real(a, b)))
    with staged_outputs(out, ("*.csv", "*.png")) as stage:
        (stage / "summary.json").write_text("{}\n")
        (stage / "z.csv").write_text("new\n")
    assert moved == ["z.csv", "summary.json"]
    assert _listing(out) == {"notes.txt": b"the user's\n", "summary.json": b"{}\n",
                             "z.csv": b"new\n"}
