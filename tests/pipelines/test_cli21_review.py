"""Review cli21: what the commands print about the input agrees with what they did, and
options shared by several commands take and refuse the same values."""

from __future__ import annotations

import json

import pytest

from terrain.cli import main


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """Run commands in an empty folder with the embedded MLflow store."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


def _simulate(vehicle: str, terrain: str, seed: int) -> None:
    assert main(["simulate", "--vehicle", vehicle, "--terrain", terrain, "--duration-s", "5",
                 "--scenario", "straight_accel", "--seed", str(seed), "--out", "runs"]) == 0


def test_audit_input_report_counts_the_runs_the_audit_skipped(workdir, capsys):
    # an AgriMaRo run among Husky runs is skipped by the audit (it replays skid-steers
    # only): the input report said "input: 2 run(s), 2 used" (MLflow input_runs_used 2) above
    # "audited 1 runs ..., skipped 1", and its jittery wheel record (never replayed) was
    # counted in the note that the replay drives the motors with it
    _simulate("husky", "ICE", 0)
    _simulate("agrimaro", "GRASS", 3)
    capsys.readouterr()
    assert main(["audit", "runs", "--json", "a.json", "--no-mlflow", "--no-progress",
                 "--bootstrap", "10", "--param-bootstrap", "0"]) == 0
    out = capsys.readouterr().out
    report = json.loads((workdir / "a.json").read_text())
    assert list(report["runs"]["skipped"]) == ["runs/GRASS/00"]
    assert "input: 2 run(s), 1 used" in out
    assert "1 run(s) skipped (the audit replays skid-steer vehicles only" in out
    assert "runs/GRASS/00" in out.split("input:")[1].split("audited")[0]
    assert report["jittery_wheel_records"]["runs"] == {}
    assert "jittery wheel-speed record" not in out
