"""Review trk23: what a ``terrain train`` that fails after fitting leaves in the MLflow store.

A training whose run ends ``FAILED`` must not leave a registered model version behind:
``models:/terrain-<dataset>/latest`` is what a robot loads, and it would serve the model
of a run the command reported as failed. The model logging is replaced by a fast stand-in
(a text artifact of the active run, registered as MLflow registers a logged model) so that
each test takes about a second; the registry itself is MLflow's, in a SQLite store in
``tmp_path``.
"""

from __future__ import annotations

import errno
import shutil

import mlflow
import pytest

import pipelines.train
from terrain.cli import main
from terrain.tracking import tracking_uri


@pytest.fixture(scope="module")
def empty_store(tmp_path_factory):
    """A new SQLite MLflow store, its tables created (MLflow's migrations take seconds)."""
    folder = tmp_path_factory.mktemp("store")
    mlflow.MlflowClient(tracking_uri=f"sqlite:///{folder / 'mlflow.db'}").search_experiments()
    return folder / "mlflow.db"


@pytest.fixture
def workdir(tmp_path, monkeypatch, vulpi_runs, empty_store):
    """An empty folder with the embedded store; ``terrain train`` fits four short runs
    (one per terrain) and logs a stand-in model."""
    shutil.copy(empty_store, tmp_path / "mlflow.db")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    firsts = {}
    for run in vulpi_runs:
        firsts.setdefault(run.terrain, run)
    monkeypatch.setattr(pipelines.train, "load_dataset", lambda name: list(firsts.values()))

    def log_model(pipeline, channels, window, classes, metadata, input_example=None,
                  progress=True):
        run_id = mlflow.active_run().info.run_id
        mlflow.log_text("stand-in model", "terrain-model/MLmodel")
        return f"runs:/{run_id}/terrain-model"

    monkeypatch.setattr(pipelines.train, "log_model", log_model)
    # MLflow's set_tracking_uri (the entry point's activate_store) exports the variable:
    # monkeypatch owns it so that it leaves with the test
    monkeypatch.setenv("MLFLOW_TRACKING_URI", "")
    previous = mlflow.get_tracking_uri()
    yield tmp_path
    mlflow.set_tracking_uri(previous)


def _state():
    """(status of each terrain-train run, versions registered as terrain-vulpi)."""
    uri = tracking_uri()
    client = mlflow.MlflowClient(tracking_uri=uri, registry_uri=uri)
    exp = client.get_experiment_by_name("terrain-train")
    runs = client.search_runs([exp.experiment_id]) if exp is not None else []
    versions = client.search_model_versions("name='terrain-vulpi'")
    return [r.info.status for r in runs], versions


TRAIN = ["train", "--dataset", "vulpi", "--model", "svm", "--window-s", "4",
         "--no-progress"]


@pytest.mark.slow
def test_a_successful_training_is_finished_and_registered(workdir, capsys):
    """The stand-in reproduces the command's success: one FINISHED run, one version."""
    assert main(TRAIN) == 0
    statuses, versions = _state()
    assert statuses == ["FINISHED"]
    assert [int(v.version) for v in versions] == [1]
    assert "registered as terrain-vulpi" in capsys.readouterr().out


@pytest.mark.slow
@pytest.mark.parametrize("failure", [OSError(errno.ENOSPC, "No space left on device"),
                                     KeyboardInterrupt()])
def test_a_training_that_fails_after_logging_its_model_registers_nothing(workdir, capsys,
                                                                         monkeypatch,
                                                                         failure):
    # the model was registered first and --model-out saved after: a full disk (or Ctrl-C)
    # while saving ended the run FAILED (exit 2: "error: No space left on device") with
    # version 1 of terrain-vulpi registered, models:/terrain-vulpi/latest serving it
    def save_model(*args, **kwargs):
        raise failure

    monkeypatch.setattr(pipelines.train, "save_model", save_model)
    code = main([*TRAIN, "--model-out", str(workdir / "m")])
    assert code == (130 if isinstance(failure, KeyboardInterrupt) else 2)
    statuses, versions = _state()
    assert statuses == ["FAILED"]
    assert versions == []
    out = capsys.readouterr().out
    assert "registered as" not in out


def test_a_training_whose_report_cannot_be_printed_registers_nothing(workdir, monkeypatch):
    # `terrain train | head -1`: the reader gone, a print after the registration raised
    # BrokenPipeError; the run ended FAILED (exit 141, quiet) with the version registered
    import builtins

    real_print = builtins.print

    def print_(*args, **kwargs):
        if args and str(args[0]).startswith("trained on"):
            raise BrokenPipeError(errno.EPIPE, "Broken pipe")
        real_print(*args, **kwargs)

    monkeypatch.setattr(builtins, "print", print_)
    monkeypatch.setattr("terrain.cli._silence_stdout", lambda: None)
    assert main(TRAIN) == 141
    statuses, versions = _state()
    assert statuses in (["FAILED"], ["FINISHED"])
    assert len(versions) == (statuses == ["FINISHED"])
