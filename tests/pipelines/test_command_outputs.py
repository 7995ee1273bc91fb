"""What the commands print, log and write says what the run held: the counts, the notes and
the names (pipelines/control_sim.py and compare.py), on known values; stand-ins keep the
runs short."""

from __future__ import annotations

import json

import mlflow

import pipelines.control_sim as control_sim
from pipelines.compare import EXPERIMENT, log_cell
from terrain.cli import main
from terrain.tracking import tracked_run, tracking_uri


def _closed_loop_stand_in(monkeypatch, speed_limit, correction, energy=12.34):
    """``run_closed_loop`` replaced by one returning these clipped-step counts per motor."""
    def run(vehicle, terrain, scenario, traction, seed, duration_s, gains, table, **kwargs):
        return None, None, {"peak_slip": 0.25, "energy_j_per_m": energy,
                            "speed_limit_clipped_steps": list(speed_limit),
                            "correction_clipped_steps": list(correction)}
    monkeypatch.setattr(control_sim, "run_closed_loop", run)


def _control_sim(tmp_path, capsys):
    out = tmp_path / "c.json"
    assert main(["control-sim", "--vehicle", "husky", "--terrain", "ice", "--terrain-source",
                 "label", "--scenario", "straight_accel", "--controller", "traction",
                 "--duration-s", "2", "--json", str(out)]) == 0
    return json.loads(out.read_text()), capsys.readouterr().out


def test_control_sim_notes_clipped_commands_when_any_motor_step_was_clipped(
        tmp_path, capsys, monkeypatch):
    # one motor clipped on 3 steps, no correction clipped: the note names the speed limit's
    # counts only (it was printed only when every motor was clipped, or both kinds were)
    _closed_loop_stand_in(monkeypatch, [0, 3, 0, 0], [0, 0, 0, 0])
    result, out = _control_sim(tmp_path, capsys)
    assert ("note: wheel commands clipped at the speed limit, physics steps per motor: "
            "{'speed_limit_clipped_steps': [0, 3, 0, 0]} (the run does not follow the "
            "command there)") in out
    assert "wrote " + str(tmp_path / "c.json") + ": peak_slip 0.250, energy 12.3 J/m" in out
    assert result["speed_limit_clipped_steps"] == [0, 3, 0, 0]
    assert result["duration_s"] == 2.0 and result["terrain"] == "ICE"
    _closed_loop_stand_in(monkeypatch, [0, 0, 0, 0], [0, 0, 0, 0], energy=None)
    _, out = _control_sim(tmp_path, capsys)
    assert "note:" not in out and "energy n/a (the run did not move)" in out


def _log_cells(tmp_path, monkeypatch, cell, rows):
    """Log one cell under a ``compare`` parent run; its child run."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    uri = tracking_uri()
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    previous = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(uri)
    try:
        with tracked_run(EXPERIMENT, run_name="compare", announce=False) as parent:
            log_cell({"cell": cell, "rows": rows})
    finally:
        mlflow.set_tracking_uri(previous)
    client = mlflow.MlflowClient(tracking_uri=uri)
    children = client.search_runs([client.get_experiment_by_name(EXPERIMENT).experiment_id],
                                  f"tags.mlflow.parentRunId = '{parent.run_id}'")
    assert len(children) == 1
    return children[0]


def test_compare_child_run_names_the_training_hop_and_protocol_and_each_history(
        tmp_path, monkeypatch):
    # a cell fitted on 0.5 s hops of 2 s windows under the leaky paper protocol: both in
    # the name (the hop once named the window length); one metric per history k
    cell = {"model": "svm", "dataset": "vulpi", "signals": "all", "window_s": 2.0, "seed": 1,
            "protocol": "paper", "train_hop_s": 0.5}
    rows = [{"history": k, "accuracy": acc, "balanced_accuracy": 0.5, "macro_f1": 0.4,
             "run_vote_accuracy": 0.6, "fit_s_per_fold": 1.0, "infer_ms_per_window": 0.1,
             "n_windows_dropped": 2} for k, acc in ((1, 0.7), (5, 0.8))]
    child = _log_cells(tmp_path, monkeypatch, cell, rows)
    assert child.info.run_name == "svm-vulpi-all-2s-seed1-paper-LEAKY-trainhop0.5s"
    assert child.data.metrics["accuracy_k1"] == 0.7
    assert child.data.metrics["accuracy_k5"] == 0.8
    assert child.data.metrics["n_windows_dropped"] == 2.0
