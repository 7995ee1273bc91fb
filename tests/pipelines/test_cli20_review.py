"""Review of the command line (cli20): option values that name a file where a folder is
read, and other inputs answered in one line naming what is wrong."""

from __future__ import annotations

import pytest
from cli_helpers import exit_code

from terrain.errors import DataFormatError
from terrain.io.shipped import default_data_dir, read_manifest


@pytest.mark.parametrize("name", ["manifest.json", "notes.txt"])
def test_slip_table_data_dir_naming_a_file_says_it_is_a_file(name, tmp_path, capsys):
    # --data-dir data/manifest.json (the manifest itself) was answered "manifest not found
    # (file data/manifest.json/manifest.json)", as if the manifest were missing
    given = tmp_path / name
    given.write_bytes((default_data_dir() / "manifest.json").read_bytes())
    assert exit_code(["slip-table", "--data-dir", str(given)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
    assert "is a file" in err[0] and "not found" not in err[0]
    assert f"{given}/manifest.json" not in err[0] and str(given) in err[0]


def test_read_manifest_of_a_file_raises_the_typed_error_naming_it(tmp_path):
    given = tmp_path / "manifest.json"
    given.write_text("{}")
    with pytest.raises(DataFormatError, match="is a file") as exc:
        read_manifest(given)
    assert str(exc.value.path) == str(given)


@pytest.mark.parametrize("window", ["0.03", "1e-9"])
def test_cv_window_too_short_says_the_window_and_rate_given(window, capsys):
    # "a window must hold at least 4 samples" named neither the --window-s given nor the
    # rate, where a window too long is answered with both
    assert exit_code(["cv", "--dataset", "borealtc", "--window-s", window]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "at least 4 samples" in err[0]
    assert f"a window of {float(window):g} s at 100 Hz" in err[0]


@pytest.mark.parametrize("uri", ["s3://bucket/slip/artifacts", "https://host/models/slip",
                                 "models:/slip-husky/2"])
def test_estimate_hands_a_slip_model_uri_to_mlflow_as_given(uri, tmp_path, monkeypatch,
                                                            capsys):
    # --slip-model-dir takes "MLflow model dir or model URI": read as a path, the URI lost
    # a slash of its '//' (s3:/bucket/..., https:/host/...), which no store resolves
    import mlflow.sklearn

    from terrain.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--scenario",
                 "straight_accel", "--duration-s", "1", "--out", "runs"]) == 0
    asked = []

    def load_model(model_uri, *args, **kwargs):
        asked.append(model_uri)
        raise OSError("no store here")

    monkeypatch.setattr(mlflow.sklearn, "load_model", load_model)
    assert exit_code(["estimate", "runs", "--out", "e.csv", "--slip-model-dir", uri]) == 2
    assert asked == [uri]
    assert f"--slip-model-dir {uri}: the model cannot be loaded" in capsys.readouterr().err
