"""`terrain slip-table`: columns fixed by issue 11, values from the library, typed errors."""

from __future__ import annotations

import io
import json

import pandas as pd

from terrain.cli import main
from terrain.control.desired_slip import TABLE_COLUMNS, build_slip_table, classifier_classes
from terrain.io.shipped import read_manifest


def _expected():
    manifest = read_manifest()
    measured = [t for ds in manifest["datasets"].values() for t in ds["terrains"]]
    return build_slip_table(classifier_classes(measured)).frame()


def test_csv_has_exactly_the_issue_columns_and_the_library_values(capsys):
    assert main(["slip-table"]) == 0
    frame = pd.read_csv(io.StringIO(capsys.readouterr().out))
    assert list(frame.columns) == list(TABLE_COLUMNS) == [
        "terrain", "target_slip_traction", "target_slip_braking", "target_slip_steady",
        "source", "method"]
    expected = _expected()
    assert list(frame["terrain"]) == list(expected["terrain"])
    for col in TABLE_COLUMNS[1:4]:
        assert (frame[col] - expected[col]).abs().max() <= 5e-5
    assert (frame["target_slip_braking"] < 0).all() and (frame["target_slip_traction"] > 0).all()


def test_json_rows(capsys):
    assert main(["slip-table", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["config"]["traction_fraction"] == 0.95
    rows = {r["terrain"]: r for r in data["rows"]}
    assert set(rows) == set(_expected()["terrain"])
    assert set(rows["SNOW"]) == set(TABLE_COLUMNS)


def test_missing_manifest_is_a_typed_message(tmp_path, capsys):
    assert main(["slip-table", "--data-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "manifest not found" in err and "Traceback" not in err
