"""Second review of the command-line layer: options refused in their own names, before any
work, where a hand mutant or a defect showed no test held them."""

from __future__ import annotations

import pytest
from cli_helpers import exit_code

from terrain.sim.simulate import MAX_DURATION_S


@pytest.mark.parametrize("value", ["inf", f"{MAX_DURATION_S + 1:g}"])
def test_slip_fit_names_a_duration_beyond_the_simulators_range_as_its_option(
        value, tmp_path, monkeypatch, capsys):
    # it said "duration_s must be in (0, 7200] s, got inf": the field, not the option
    monkeypatch.chdir(tmp_path)
    assert exit_code(["slip-fit", "--duration-s", value, "--cache-dir", "c", "--out", "o"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("terrain slip-fit: error: --duration-s: ") and err.count("\n") == 1
    assert f"(0, {MAX_DURATION_S:g}] s" in err
    assert not any(tmp_path.iterdir())      # nothing simulated, no MLflow run opened


def test_a_model_directory_that_cannot_be_listed_is_a_usage_error_not_a_traceback(
        tmp_path, monkeypatch, capsys):
    # a folder one may write into but not list (mode -wx, as an upload drop box): listing
    # it raised PermissionError while the options were read, outside the one-line handler
    from pathlib import Path

    target = tmp_path / "drop"
    target.mkdir()
    listing = Path.iterdir

    def refuse(path):
        if path == target:
            raise PermissionError(13, "Permission denied", str(path))
        return listing(path)

    monkeypatch.setattr(Path, "iterdir", refuse)
    assert exit_code(["train", "--model-out", str(target)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert (f"argument --model-out: cannot use {str(target)!r} as model directory: "
            "Permission denied") in err.splitlines()[-1]
