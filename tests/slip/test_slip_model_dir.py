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
