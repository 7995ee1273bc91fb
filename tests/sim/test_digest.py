"""Digests of the simulator (terrain/sim/digest.py) and the slip-fit cache keyed by them: a run
simulated before a change of the simulator's code or parameters is never reused."""

from __future__ import annotations

import importlib

import pytest

import terrain.slip.dataset as dataset
from terrain.errors import ConfigError
from terrain.sim.digest import SIMULATOR_MODULES, simulator_digest, source_digest
from terrain.sim.simulate import SimConfig


def _package(root, name, body):
    pkg = root / name
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "physics.py").write_text(body)
    importlib.invalidate_caches()
    return pkg


def test_source_digest_follows_every_byte_of_a_package(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    pkg = _package(tmp_path, "digest_probe_pkg", "MU = 0.8\n")
    before = source_digest(["digest_probe_pkg"])
    assert len(before) == 40 and source_digest(["digest_probe_pkg"]) == before
    (pkg / "physics.py").write_text("MU = 0.8  # peak friction\n")   # a comment counts
    assert source_digest(["digest_probe_pkg"]) != before
    (pkg / "physics.py").write_text("MU = 0.8\n")
    assert source_digest(["digest_probe_pkg"]) == before
    (pkg / "sub").mkdir()
    (pkg / "sub" / "more.py").write_text("")   # a new file below the package counts
    assert source_digest(["digest_probe_pkg"]) != before


def test_source_digest_of_an_unknown_module_is_a_config_error():
    with pytest.raises(ConfigError, match="no_such_module_xyz"):
        source_digest(["no_such_module_xyz"])


def test_simulator_digest_separates_vehicles_and_terrains_not_their_order():
    a = simulator_digest("husky", ("SNOW", "ICE"))
    assert a == simulator_digest("husky", ("ice", "snow"))
    assert a != simulator_digest("agrimaro", ("SNOW", "ICE"))
    assert a != simulator_digest("husky", ("SNOW",))
    assert set(SIMULATOR_MODULES) >= {"terrain.sim", "terrain.terramechanics"}
    with pytest.raises(ConfigError, match="unknown vehicle"):
        simulator_digest("tractor", ("SNOW",))


def test_slip_cache_reuses_a_run_only_while_the_simulator_is_unchanged(tmp_path, monkeypatch):
    config = SimConfig(terrains=("SNOW",), scenario="straight_accel", duration_s=2.0, seed=5)
    first = dataset.simulated_run(config, tmp_path)
    files = sorted(tmp_path.iterdir())
    assert [f.name for f in files] == [dataset.cache_key(config)]
    again = dataset.simulated_run(config, tmp_path)        # read back, not simulated
    assert again.run_id == first.run_id == "sim/SNOW/straight_accel/5"
    assert again.streams["imu"].equals(first.streams["imu"])
    assert dataset.cache_key(config) != dataset.cache_key(SimConfig(
        terrains=("SNOW",), scenario="straight_accel", duration_s=2.0, seed=6))
    other_seed = SimConfig(terrains=("SNOW",), scenario="straight_accel", duration_s=2.0,
                           seed=15)
    dataset.simulated_run(other_seed, tmp_path)
    assert len(list(tmp_path.iterdir())) == 2
    # another simulator (code or parameters) gives another key: the old run is not reused,
    # it is replaced (one file per cell and settings), and the other cell is kept
    monkeypatch.setattr(dataset, "simulator_digest", lambda vehicle, terrains: "changed")
    new_key = dataset.cache_key(config)
    assert new_key != files[0].name and new_key.endswith("_changed.joblib")
    dataset.simulated_run(config, tmp_path)
    names = {f.name for f in tmp_path.iterdir()}
    assert new_key in names and files[0].name not in names and len(names) == 2


def test_two_writers_of_one_cache_cell_do_not_trip_over_one_temporary_file(tmp_path,
                                                                           monkeypatch):
    # both writers dumped to the one "<key>.tmp": a writer whose file the other had moved
    # into place before its own rename failed with FileNotFoundError (and two writers at once
    # wrote into one file). Each write now has a temporary file of its own.
    config = SimConfig(terrains=("SNOW",), scenario="straight_accel", duration_s=2.0, seed=5)
    real_dump = dataset.joblib.dump
    calls = []

    def dump_meanwhile(value, filename):
        calls.append(filename)
        out = real_dump(value, filename)
        if len(calls) == 1:     # another process stores the same cell before this one renames
            dataset.simulated_run(config, tmp_path)
        return out

    monkeypatch.setattr(dataset.joblib, "dump", dump_meanwhile)
    run = dataset.simulated_run(config, tmp_path)
    assert len(calls) == 2 and calls[0] != calls[1]
    assert [f.name for f in tmp_path.iterdir()] == [dataset.cache_key(config)]
    assert dataset.simulated_run(config, tmp_path).streams["imu"].equals(run.streams["imu"])


def test_simulator_digest_follows_the_vehicles_default_sensor_settings(monkeypatch):
    """The default sensor settings (rates, noise) shape every simulated run: a change of
    them must invalidate the caches as a change of the vehicle's parameters does."""
    import dataclasses

    import terrain.sim.digest as digest

    before = simulator_digest("husky", ("SNOW",))
    sensors = dict(digest.DEFAULT_SENSORS)
    husky = sensors["husky"]
    sensors["husky"] = dataclasses.replace(husky, wheel_rate_hz=2.0 * husky.wheel_rate_hz)
    monkeypatch.setattr(digest, "DEFAULT_SENSORS", sensors)
    assert simulator_digest("husky", ("SNOW",)) != before
    monkeypatch.setattr(digest, "DEFAULT_SENSORS", {**sensors, "husky": husky})
    assert simulator_digest("husky", ("SNOW",)) == before
