"""What the ``terrain`` entry point prints for a reported error: one line, naming the file
of an OS error, a long message cut to a readable length."""

from __future__ import annotations

import pytest

from terrain.cli import main
from terrain.errors import ConfigError


def _fail_with(monkeypatch, exc):
    import pipelines.slip_table as slip_table

    def fail(args):
        raise exc

    monkeypatch.setattr(slip_table, "main", fail)


@pytest.mark.parametrize("exc", [
    FileNotFoundError(2, "No such file or directory", "/nowhere/runs/imu_00.csv"),
    PermissionError(13, "Permission denied", "/nowhere/runs/imu_00.csv"),
])
def test_an_os_error_names_its_file(exc, monkeypatch, capsys):
    _fail_with(monkeypatch, exc)
    assert main(["slip-table"]) == 2
    err = capsys.readouterr().err
    assert err == (f"terrain slip-table: error: {exc.strerror}: /nowhere/runs/imu_00.csv\n")


def test_a_long_message_is_cut_to_500_characters(monkeypatch, capsys):
    _fail_with(monkeypatch, ConfigError("x" * 2000))
    assert main(["slip-table"]) == 2
    err = capsys.readouterr().err
    prefix = "terrain slip-table: error: "
    assert err == prefix + "x" * 497 + "...\n"
    _fail_with(monkeypatch, ConfigError("y" * 500))     # at the limit: kept whole
    assert main(["slip-table"]) == 2
    assert capsys.readouterr().err == prefix + "y" * 500 + "\n"


def test_a_data_warning_is_one_line_saying_warning(monkeypatch, capsys):
    # what a reader assumed (DataWarning) reads "warning"; any other warning keeps its kind
    import warnings

    from terrain.errors import DataWarning
    import pipelines.slip_table as slip_table

    def warn(args):
        warnings.warn("3 blank line(s) skipped in imu_00.csv", DataWarning)
        warnings.warn("something else", UserWarning)
        return 0

    monkeypatch.setattr(slip_table, "main", warn)
    assert main(["slip-table"]) == 0
    assert capsys.readouterr().err.splitlines() == [
        "terrain: warning: 3 blank line(s) skipped in imu_00.csv",
        "terrain: UserWarning: something else"]
