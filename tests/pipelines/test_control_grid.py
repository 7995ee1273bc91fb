"""`terrain control-grid` end to end on a one-cell grid: tune, run off/on, tabulate."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from terrain.cli import main as cli_main
from terrain.control.grid import TUNING_SEEDS


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """Run the command in an empty folder with the embedded MLflow store."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


@pytest.mark.slow
def test_control_grid_tunes_on_other_seeds_and_cuts_the_ice_start_up_slip(workdir, capsys):
    rc = cli_main(["control-grid", "--vehicles", "husky", "--terrains", "ICE", "--seeds", "0",
                   "--duration-s", "4", "--kp-grid", "2", "5", "--ki-grid", "10",
                   "--out", "g"])
    assert rc == 0
    # every candidate of the grid is scored, and the chosen gains are the cheapest one
    tuning = pd.read_csv(workdir / "g" / "tuning_husky.csv")
    assert sorted(tuning.kp) == [2.0, 5.0] and set(tuning.ki) == {10.0}
    best = tuning.loc[tuning.cost.idxmin()]
    summary = json.loads((workdir / "g" / "summary.json").read_text())
    assert summary["gains"]["husky"] == [best.kp, best.ki]
    # tuning never sees the evaluation seed
    assert 0 not in summary["tuning_seeds"] and summary["tuning_seeds"] == list(TUNING_SEEDS)
    runs = pd.read_csv(workdir / "g" / "runs.csv")
    assert sorted(runs.controller) == ["off", "traction"]
    # the catalogue's ice (peak friction 0.05) spins the rims at start-up without control;
    # the traction controller holds the slip near its target (docs/control_validation.md:
    # 77 % peak cut on the Husky)
    row = pd.read_csv(workdir / "g" / "comparison.csv").iloc[0]
    assert row.peak_slip_off > 0.3
    assert row.peak_slip_cut > 0.5
    assert row.slip_rmse_on < 0.5 * row.slip_rmse_off
    assert "| husky | ICE | straight_accel |" in (workdir / "g" / "comparison.md").read_text()
    assert (workdir / "g" / "slip_husky_ICE_straight_accel.png").stat().st_size > 0
    assert "peak_slip_cut" in capsys.readouterr().out
    # the MLflow run holds the same tables as CSV under .csv names (they were CSV text
    # named tuning_husky.json and comparison.json)
    import mlflow
    client = mlflow.MlflowClient(tracking_uri=f"sqlite:///{workdir / 'mlflow.db'}")
    (run,) = client.search_runs([client.get_experiment_by_name("terrain-control").experiment_id])
    logged = {a.path for a in client.list_artifacts(run.info.run_id)}
    assert {"tuning_husky.csv", "comparison.csv"} <= logged
    assert not {"tuning_husky.json", "comparison.json"} & logged


@pytest.mark.slow
def test_terrain_names_in_lower_case_keep_the_slip_limit_bound(workdir):
    # the catalogue reads terrain names in any case (the runs simulate snow), so the grid's
    # tables and its quasi-static slip-limit bound (soft terrains) must not depend on it
    rc = cli_main(["control-grid", "--vehicles", "husky", "--terrains", "snow", "--no-tune",
                   "--duration-s", "2", "--out", "g"])
    assert rc == 0

    def strict(token):      # NaN / Infinity are not JSON (jq, JSON.parse refuse them)
        raise ValueError(f"not JSON: {token}")

    summary = json.loads((workdir / "g" / "summary.json").read_text(), parse_constant=strict)
    assert [r["terrain"] for r in summary["comparison"]] == ["SNOW"]
    assert [b["terrain"] for b in summary["slip_limit_bound"]] == ["SNOW"]
