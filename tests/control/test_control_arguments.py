"""Argument validation of ``terrain control-sim`` (duration) and ``terrain slip-table``
(manifest structure): one-line typed errors instead of tracebacks (fuzzing findings)."""

from __future__ import annotations

import json

import pytest

import pipelines.control_sim as control_sim
from pipelines.slip_table import measured_terrains
from terrain.cli import main
from terrain.errors import DataFormatError
from terrain.io.shipped import read_manifest


def _error_line(capsys, command: str) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith(f"terrain {command}: error:")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize("vehicle, minimum", [("husky", "0.16"), ("agrimaro", "0.04")])
def test_control_sim_too_short_duration_fails_before_any_training(vehicle, minimum, tmp_path,
                                                                  capsys, monkeypatch):
    def no_training(*args, **kwargs):
        raise AssertionError("the classifier must not be trained for a bad duration")

    monkeypatch.setattr(control_sim, "decision_source", no_training)
    code = main(["control-sim", "--vehicle", vehicle, "--terrain", "SNOW", "--scenario",
                 "straight_accel", "--controller", "traction", "--duration-s", "0.001",
                 "--json", str(tmp_path / "m.json")])
    assert code == 2
    line = _error_line(capsys, "control-sim")
    assert "too short" in line and f"minimum is {minimum} s" in line
    assert not (tmp_path / "m.json").exists()


_SIM = ["control-sim", "--vehicle", "husky", "--terrain", "ICE", "--scenario", "straight_accel",
        "--controller", "traction"]
_GRID = ["control-grid", "--vehicles", "husky", "--terrains", "ICE"]


@pytest.mark.parametrize("argv, text", [
    # each said the setting's name: duration_s must be in (0, 7200] s; traction control
    # settings must be finite, got kp=nan; gains must be >= 0, got kp=2.0, ki=-1.0, kd=0.0
    (_SIM + ["--duration-s", "-5"], "argument --duration-s: must be a finite number in (0, 7200]"),
    (_SIM + ["--duration-s", "nan"], "argument --duration-s: must be a finite number in (0, 7200]"),
    (_SIM + ["--duration-s", "10000"],
     "argument --duration-s: must be a finite number in (0, 7200] s, got 10000"),
    (_SIM + ["--duration-s", "0.01"], "--duration-s: a duration of 0.01 s is too short"),
    (_SIM + ["--kp", "nan"], "argument --kp: must be a finite number >= 0, got nan"),
    (_SIM + ["--ki", "-1"], "argument --ki: must be a finite number >= 0, got -1"),
    (_SIM + ["--kp", "inf"], "argument --kp: must be a finite number >= 0, got inf"),
    (_GRID + ["--duration-s", "inf"],
     "argument --duration-s: must be a finite number in (0, 7200]"),
    (_GRID + ["--duration-s", "10000"],
     "argument --duration-s: must be a finite number in (0, 7200] s, got 10000"),
    (_GRID + ["--kp-grid", "2", "nan"], "argument --kp-grid: must be a finite number >= 0"),
    (_GRID + ["--ki-grid", "-1"], "argument --ki-grid: must be a finite number >= 0, got -1"),
])
def test_control_commands_name_the_option_of_a_bad_value(argv, text, tmp_path, capsys,
                                                         monkeypatch):
    def no_training(*args, **kwargs):
        raise AssertionError("the classifier must not be trained for a bad option")

    monkeypatch.setattr(control_sim, "decision_source", no_training)
    monkeypatch.chdir(tmp_path)
    out = ["--json", "m.json"] if argv[0] == "control-sim" else ["--out", "g"]
    try:
        code = main(argv + out)
    except SystemExit as exc:   # argparse's own usage error
        code = exc.code
    assert code == 2
    line = _error_line(capsys, argv[0])
    assert text in line, line
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("source", ["label", "live-sim"])
def test_control_sim_refuses_a_model_it_would_not_use(source, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(control_sim, "decision_source", lambda *a, **k: (None, {}))
    code = main(["control-sim", "--vehicle", "husky", "--terrain", "SNOW", "--scenario",
                 "straight_accel", "--controller", "traction", "--terrain-source", source,
                 "--model", str(tmp_path / "model"), "--json", str(tmp_path / "m.json")])
    assert code == 2
    line = _error_line(capsys, "control-sim")
    assert f"--model is used only with --terrain-source model, not '{source}'" in line


def test_control_sim_runs_at_the_minimum_duration(tmp_path, capsys):
    out = tmp_path / "m.json"
    assert main(["control-sim", "--vehicle", "husky", "--terrain", "SNOW", "--scenario",
                 "straight_accel", "--controller", "traction", "--terrain-source", "label",
                 "--duration-s", "0.16", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["duration_s"] == 0.16


BAD_MANIFESTS = [
    ([], "must be a JSON object"),
    ({"format": 1}, "'datasets' is missing"),
    ({"datasets": ["borealtc"]}, "'datasets' must be an object"),
    ({"datasets": {}}, "lists no dataset"),
    ({"datasets": {"vulpi": 3}}, "'datasets.vulpi' must be an object"),
    ({"datasets": {"vulpi": {"robot": "husky"}}}, "'datasets.vulpi.terrains' is missing"),
    ({"datasets": {"vulpi": {"terrains": "SNOW"}}},
     "'datasets.vulpi.terrains' must be a list"),
    ({"datasets": {"vulpi": {"terrains": []}}}, "is an empty list"),
    ({"datasets": {"vulpi": {"terrains": ["SNOW", 7]}}}, "'datasets.vulpi.terrains[1]'"),
    ({"datasets": {"vulpi": {"terrains": ["SNOW", "MUD"]}}},
     "'datasets.vulpi.terrains[1]': unknown terrain 'MUD'"),
]


@pytest.mark.parametrize("manifest, message", BAD_MANIFESTS)
def test_badly_structured_manifest_is_a_one_line_error_naming_file_and_key(
        manifest, message, tmp_path, capsys):
    path = tmp_path / "manifest.json"
    path.write_text(json.dumps(manifest))
    with pytest.raises(DataFormatError) as info:
        measured_terrains(manifest, path)
    assert message in str(info.value) and info.value.path == str(path)
    assert main(["slip-table", "--data-dir", str(tmp_path)]) == 2
    line = _error_line(capsys, "slip-table")
    assert message in line and str(path) in line
    assert "unknown terrain 'N'" not in line


def test_shipped_manifest_passes_the_structure_check():
    terrains = measured_terrains(read_manifest(), "data/manifest.json")
    assert {"SNOW", "ICE", "ASPHALT", "PLOUGHED"} <= set(terrains) and len(terrains) == 9
