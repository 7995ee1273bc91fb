"""``--slip-model-dir``: a folder is checked before MLflow sees it; only a URI with a scheme
of two or more letters goes to MLflow as it is (``C:/models`` is a Windows folder)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipelines.slip_model import load_slip_model_dir
from terrain.errors import ConfigError


@pytest.mark.parametrize("name", ["C:/no/such/model", "c:/models"])
def test_a_drive_letter_path_is_a_folder_not_a_uri(name):
    with pytest.raises(ConfigError, match=f"--slip-model-dir {name}: no such folder$"):
        load_slip_model_dir(Path(name))


def test_a_uri_goes_to_mlflow_and_its_failure_is_named(tmp_path):
    with pytest.raises(ConfigError, match="--slip-model-dir file:.*the model cannot be loaded"):
        load_slip_model_dir(Path(f"file://{tmp_path}/none"))


def test_no_store_means_no_learned_model_and_no_store_is_created(tmp_path, monkeypatch):
    # without --slip-model-dir the registered model is looked up; a store that does not
    # exist is said, and not created empty by the look-up
    from pipelines.slip_model import resolve_slip_model

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{tmp_path / 'none' / 'mlflow.db'}")
    model, where = resolve_slip_model(None)
    assert model is None and where.startswith("no tracking store at sqlite:///")
    assert list(tmp_path.iterdir()) == []
