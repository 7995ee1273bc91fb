"""Argument validation of ``terrain simulate`` and :class:`terrain.sim.SimConfig` (fuzzing
findings): a too-short duration, an empty terrain name, a repeated effect."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.cli import main
from terrain.errors import ConfigError
from terrain.io.measured import read_runs_dir
from terrain.io.writer import write_run
from terrain.sim import (Effects, SensorSettings, SimConfig, make_commands, minimum_duration_s,
                         parse_effects, parse_terrain_list, simulate)
from terrain.sim.dynamics import integrate
from terrain.vehicles import get_vehicle

#: shortest run per vehicle at the default sensors and 100 Hz physics (the slowest stream:
#: Husky wheels 6.5 Hz, tracked wheels 10 Hz, AgriMaRo camera 30 Hz)
MINIMUM_S = {"husky": 0.16, "tracked": 0.1, "agrimaro": 0.04}


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("terrain simulate: error:")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize("vehicle", ["husky", "agrimaro"])
@pytest.mark.parametrize("duration", ["0.001", "0.005"])
def test_duration_below_one_physics_step_is_a_one_line_error(vehicle, duration, tmp_path,
                                                             capsys):
    code = main(["simulate", "--vehicle", vehicle, "--terrain", "SNOW", "--duration-s",
                 duration, "--out", str(tmp_path)])
    assert code == 2
    line = _one_line_error(capsys)
    assert "too short" in line and f"minimum is {MINIMUM_S[vehicle]:g} s" in line
    assert not any(tmp_path.iterdir())          # nothing written


def test_husky_run_of_one_wheel_sample_is_refused(tmp_path, capsys):
    # 0.1 s used to write a 1-row pro_00.csv that `terrain estimate` then refused
    assert main(["simulate", "--vehicle", "husky", "--terrain", "SNOW", "--duration-s", "0.1",
                 "--out", str(tmp_path)]) == 2
    line = _one_line_error(capsys)
    assert "pro at 6.5 Hz" in line and "minimum is 0.16 s" in line


@pytest.mark.parametrize("vehicle", sorted(MINIMUM_S))
def test_minimum_duration_is_the_shortest_run_the_readers_accept(vehicle, tmp_path):
    minimum, why = minimum_duration_s(vehicle)
    assert minimum == pytest.approx(MINIMUM_S[vehicle])
    assert "physics steps" in why
    step = 0.01
    with pytest.raises(ConfigError, match=f"minimum is {MINIMUM_S[vehicle]:g} s"):
        SimConfig(vehicle=vehicle, terrains=("SNOW",), duration_s=minimum - step)
    run = simulate(SimConfig(vehicle=vehicle, terrains=("SNOW",), duration_s=minimum))
    assert min(len(frame) for frame in run.streams.values()) >= 2
    write_run(run, tmp_path)
    (back,) = read_runs_dir(tmp_path)             # every stream file is accepted
    assert set(back.streams) == set(run.streams)


def test_minimum_duration_follows_the_sensor_settings():
    slow = SensorSettings(wheel_rate_hz=2.0)
    minimum, why = minimum_duration_s("husky", slow)
    assert minimum == pytest.approx(0.5) and "pro at 2 Hz" in why
    with pytest.raises(ConfigError, match="minimum is 0.5 s"):
        SimConfig(vehicle="husky", duration_s=0.3, sensors=slow)
    assert minimum_duration_s("husky", physics_rate_hz=50.0)[0] == pytest.approx(0.16)


@pytest.mark.parametrize("rate", [0.0, -100.0, float("nan")])
def test_a_rate_that_is_not_a_finite_rate_above_zero_is_refused_naming_it(rate):
    # 0 was a ZeroDivisionError in both; a negative rate gave an empty time grid
    from terrain.sim.sensors import sample_times

    with pytest.raises(ConfigError, match="minimum_duration_s.physics_rate_hz must be"):
        minimum_duration_s("husky", physics_rate_hz=rate)
    with pytest.raises(ConfigError, match="sample_times.rate_hz must be"):
        sample_times(1.0, rate)


def test_duration_bounds_still_hold():
    with pytest.raises(ConfigError, match=r"\(0, 7200\]"):
        SimConfig(duration_s=0)
    with pytest.raises(ConfigError, match=r"\(0, 7200\]"):
        SimConfig(duration_s=7200.5)
    with pytest.raises(ConfigError, match=r"\(0, 7200\]"):
        SimConfig(duration_s=float("nan"))


@pytest.mark.parametrize("seed", [2.7, -1, True])
def test_a_seed_that_is_not_a_whole_number_is_refused(seed):
    # 2.7 was simulated as seed 2 (and its run labelled sim/<TERRAIN>/2) without a word
    with pytest.raises(ConfigError, match="seed must be an integer >= 0"):
        SimConfig(seed=seed)
    assert SimConfig(seed=np.int64(3)).seed == 3 and SimConfig(seed=3.0).seed == 3


def test_library_steps_refuse_a_grid_of_one_step():
    rng = np.random.default_rng(0)
    with pytest.raises(ConfigError, match="shorter than one physics step"):
        make_commands("straight_accel", 0.001, 0.01, rng, 1.0)
    vehicle = get_vehicle("husky")
    with pytest.raises(ConfigError, match="at least 2 steps"):
        integrate(vehicle, vehicle.contact_geometry(), (), 25.0, np.zeros(1), np.zeros((1, 3)),
                  0.0, 1.0)


@pytest.mark.parametrize("field, value", [("wheel_rate_hz", 0.0), ("imu_rate_hz", -100.0),
                                          ("cam_rate_hz", float("inf")),
                                          ("gyro_noise_rad_s", -0.1),
                                          ("current_noise_a", float("nan")),
                                          ("accel_noise_m_s2", float("inf"))])
def test_sensor_settings_refuse_bad_rates_and_noise(field, value):
    with pytest.raises(ConfigError, match=field):
        SensorSettings(**{field: value})


@pytest.mark.parametrize("text", ["SNOW,", ",SNOW", "ICE,,SNOW", "", " , "])
def test_empty_terrain_name_is_refused(text, tmp_path, capsys):
    with pytest.raises(ConfigError, match="empty terrain name"):
        parse_terrain_list(text)
    assert main(["simulate", "--vehicle", "husky", "--terrain", text, "--duration-s", "1",
                 "--out", str(tmp_path)]) == 2
    assert "empty terrain name" in _one_line_error(capsys)


def test_terrain_list_is_split_stripped_and_upper_cased():
    assert parse_terrain_list("snow") == ("SNOW",)
    assert parse_terrain_list(" ice , Snow") == ("ICE", "SNOW")


def test_terrains_as_one_string_is_refused_not_split_into_letters():
    with pytest.raises(ConfigError, match="sequence of terrain names"):
        SimConfig(terrains="SNOW")
    with pytest.raises(ConfigError, match="empty terrain name"):
        SimConfig(terrains=("SNOW", ""))


def test_repeated_effect_is_refused(tmp_path, capsys):
    with pytest.raises(ConfigError, match="effect gyro_bias given twice"):
        parse_effects(["gyro_bias=0.01", "gyro_bias=0.02"])
    with pytest.raises(ConfigError, match="given twice"):
        parse_effects(["icr_expansion=1.4", " icr_expansion = 1.4"])   # even the same value
    assert parse_effects(["gyro_bias=0.01", "wheel_lag=0.1"]).gyro_bias == 0.01
    assert main(["simulate", "--vehicle", "husky", "--terrain", "SNOW", "--duration-s", "1",
                 "--effect", "icr_expansion=1.2", "--effect", "icr_expansion=1.6",
                 "--out", str(tmp_path)]) == 2
    line = _one_line_error(capsys)
    assert "icr_expansion given twice" in line


@pytest.mark.slow
def test_a_listed_terrain_the_path_never_reaches_is_named(tmp_path, capsys):
    # a spin in place covers no distance: the second terrain of the list never comes, and the
    # run (folder MIXED, meta "terrains" as listed) holds the first only; said in a note
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE,SNOW", "--scenario",
                 "spin", "--duration-s", "5", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "note: terrain(s) SNOW never reached: the path covers 0.0 m" in out
    assert "the run holds ICE only" in out
    (run,) = read_runs_dir(tmp_path)
    assert set(run.streams["truth"]["terrain"]) == {"ICE"}
    # a path long enough for both: no note
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE,SNOW", "--segment-m",
                 "2", "--scenario", "straight_accel", "--duration-s", "10", "--out",
                 str(tmp_path / "both")]) == 0
    assert "never reached" not in capsys.readouterr().out


def test_icr_expansion_on_a_steered_vehicle_is_refused(tmp_path, capsys):
    # simulate() applies chi to skid-steered vehicles only: on the AgriMaRo the run's
    # metadata listed it as active and every stream came out identical to the run without
    with pytest.raises(ConfigError, match="icr_expansion is a skid-steer effect"):
        SimConfig(vehicle="agrimaro", effects=parse_effects(["icr_expansion=1.5"]))
    SimConfig(vehicle="agrimaro", effects=parse_effects(["gyro_bias=0.03"]))
    SimConfig(vehicle="tracked", effects=parse_effects(["icr_expansion=1.5"]))
    assert main(["simulate", "--vehicle", "agrimaro", "--terrain", "SNOW", "--effect",
                 "icr_expansion=1.5", "--out", str(tmp_path)]) == 2
    assert "the agrimaro is steered" in _one_line_error(capsys)
    assert not any(tmp_path.iterdir())


def test_grade_resistance_on_level_ground_is_refused(tmp_path, capsys):
    # grade_resistance adds value * |pitch|: on a level scenario (every one but slope_turn)
    # the run's metadata listed it as active and every stream came out identical to the run
    # without it (husky orchard, 2 s, seed 1, 50 A/rad)
    with pytest.raises(ConfigError, match="grade_resistance .* level ground"):
        SimConfig(vehicle="husky", scenario="orchard",
                  effects=parse_effects(["grade_resistance=50"]))
    SimConfig(vehicle="husky", scenario="slope_turn",
              effects=parse_effects(["grade_resistance=50"]))
    SimConfig(vehicle="husky", scenario="orchard", effects=parse_effects(["gyro_bias=0.03"]))
    assert main(["simulate", "--vehicle", "husky", "--scenario", "spin", "--terrain", "SNOW",
                 "--effect", "grade_resistance=50", "--out", str(tmp_path)]) == 2
    assert "the spin scenario is on level ground" in _one_line_error(capsys)
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_write_run_refuses_an_index_of_a_measured_run_and_unreadable_stream_names(tmp_path):
    # measured runs have no meta_XX.json: index 3 overwrote their pro_03.csv
    from dataclasses import replace
    run = simulate(SimConfig(vehicle="tracked", terrains=("ASPHALT",), duration_s=3.0))
    folder = tmp_path / "ASPHALT"
    folder.mkdir()
    (folder / "pro_03.csv").write_text("measured\n")
    with pytest.raises(ConfigError, match="already used"):
        write_run(run, tmp_path, index=3)
    assert (folder / "pro_03.csv").read_text() == "measured\n"
    odd = replace(run, streams={**run.streams, "vis_odom": run.streams["imu"]})
    with pytest.raises(ConfigError, match="never read back"):
        write_run(odd, tmp_path, index=4)
    # the vehicle comes back even when the run's meta does not name it
    write_run(replace(run, meta={}), tmp_path / "other", index=5)
    (back,) = read_runs_dir(tmp_path / "other")
    assert back.vehicle == "tracked"


def test_lower_case_terrain_names_label_the_run_with_the_catalogue_name(tmp_path):
    """SimConfig accepts any case (get_terrain does), but the run was labelled with the name
    as given: terrains=("snow",) gave run sim/snow/0, folder snow/ and a truth stream of
    SNOW, so the CLI's note said "terrain(s) snow never reached ... the run holds SNOW"."""
    from pipelines.simulate import unreached_terrains_note
    config = SimConfig(vehicle="husky", terrains=("snow", "Ice"), scenario="spin",
                       duration_s=0.5, seed=0)
    assert config.terrains == ("SNOW", "ICE")
    run = simulate(SimConfig(vehicle="husky", terrains=("snow",), scenario="spin",
                             duration_s=0.5, seed=0))
    assert run.terrain == "SNOW" and run.run_id == "sim/SNOW/spin/0"
    assert run.meta["terrains"] == ["SNOW"]
    assert set(run.streams["truth"]["terrain"]) == {"SNOW"}
    paths = write_run(run, tmp_path)
    assert paths["imu"].parent.name == "SNOW"
    single = SimConfig(vehicle="husky", terrains=("snow",), scenario="spin", duration_s=0.5)
    assert unreached_terrains_note(run, single) is None


@pytest.mark.parametrize("kwargs", [dict(seed=float("inf")), dict(seed=float("nan")),
                                    dict(seed=None), dict(duration_s="10"),
                                    dict(duration_s=True), dict(duration_s=None),
                                    dict(physics_rate_hz="100"), dict(segment_length_m="5"),
                                    dict(effects=None), dict(effects={"gyro_bias": 0.1})])
def test_simconfig_refuses_a_value_of_the_wrong_type_with_a_config_error(kwargs):
    """seed inf raised OverflowError, NaN ValueError, None TypeError; duration_s "10" and
    True were accepted (the text kept in the config, True simulated as 1 s); effects None
    or a dict raised AttributeError. Each is now a ConfigError naming the field."""
    name = next(iter(kwargs))
    with pytest.raises(ConfigError, match=name):
        SimConfig(**kwargs)


@pytest.mark.parametrize("length", [float("inf"), 0.0, -1.0, float("nan")])
def test_simconfig_refuses_a_segment_length_that_is_not_a_finite_length(length):
    """inf was accepted (the CLI's --segment-m refuses it): a two-terrain run stayed on its
    first terrain, labelled MIXED, and its meta_XX.json held segment_length_m Infinity,
    which is not JSON."""
    with pytest.raises(ConfigError, match=rf"^segment_length_m must be a finite length > 0, "
                                          rf"m, got {length}$"):
        SimConfig(terrains=("ICE", "SNOW"), segment_length_m=length)


@pytest.mark.parametrize("cls, kwargs", [(SensorSettings, dict(imu_rate_hz="x")),
                                         (SensorSettings, dict(gyro_noise_rad_s=None)),
                                         (SensorSettings, dict(wheel_rate_hz="6.5")),
                                         (Effects, dict(gyro_bias="0.1")),
                                         (Effects, dict(gyro_bias=None)),
                                         (Effects, dict(wheel_lag="x"))])
def test_sensor_settings_and_effects_refuse_text_and_none(cls, kwargs):
    """SensorSettings(imu_rate_hz="x") raised ValueError, None TypeError, and "6.5" was
    kept as text; Effects(gyro_bias="0.1") was accepted with the text stored, None raised
    TypeError. Now a ConfigError names the field (parse_effects still converts text)."""
    name = next(iter(kwargs))
    with pytest.raises(ConfigError, match=name):
        cls(**kwargs)
    assert parse_effects(["gyro_bias=0.1"]).gyro_bias == 0.1


@pytest.mark.slow
def test_wheel_commands_clipped_at_the_speed_limit_are_counted_and_said(tmp_path, capsys):
    # the random scenario's segments (speed up to 0.95 of the limit, yaw rate up to 0.8 rad/s)
    # ask the outer side for more than the wheel speed limit: the Husky's seed 1 asks the
    # left side for more on 431 of 6001 physics steps; clipped per side, as documented, and
    # not counted anywhere
    run = simulate(SimConfig(vehicle="husky", scenario="random", duration_s=60.0, seed=1))
    assert run.meta["speed_limit_clipped_steps"] == [431, 0]
    assert simulate(SimConfig(vehicle="husky", scenario="random", duration_s=60.0,
                              seed=0)).meta["speed_limit_clipped_steps"] == [0, 0]
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--duration-s", "60",
                 "--seed", "1", "--out", str(tmp_path)]) == 0
    assert ("note: the random scenario asked for more than the wheel speed limit (6.06 rad/s): "
            "each side's command clipped to it on left 431, right 0 of 6001 physics steps (the "
            "run does not follow the command there)") in capsys.readouterr().out
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--duration-s", "60",
                 "--seed", "0", "--out", str(tmp_path)]) == 0
    assert "speed limit" not in capsys.readouterr().out


@pytest.mark.parametrize("name, lower, upper", [
    ("icr_expansion", 1.0, 20.0), ("gyro_bias", -0.5, 0.5), ("wheel_lag", 0.0, 2.0),
    ("turning_resistance", 0.0, 50.0), ("current_offset", -20.0, 20.0),
    ("grade_resistance", 0.0, 200.0)])
def test_each_planted_effect_takes_its_documented_range_ends_included(name, lower, upper):
    """The ranges of the module's table: chi below 1 would make the robot turn faster than
    differential drive, a negative turning resistance would lower the current in turns; a
    gyro bias and a current offset go either way (left or right)."""
    for value in (lower, upper):
        assert Effects(**{name: value}).as_dict()[name] == value
    for value in (lower - 0.01, upper + 0.01):
        with pytest.raises(ConfigError, match=name):
            Effects(**{name: value})


def test_an_effect_item_with_two_equals_signs_is_refused():
    """``NAME=VALUE=...`` is malformed: its value is not a number, rather than the text after
    the second ``=`` being dropped."""
    with pytest.raises(ConfigError, match="gyro_bias needs a number"):
        parse_effects(["gyro_bias=0.1=0.2"])


@pytest.mark.slow
def test_segment_m_with_one_terrain_is_said_not_silently_ignored(tmp_path, capsys):
    # --segment-m sets where the terrain changes along the path: with one terrain it changed
    # nothing and nothing said so (estimate says so of an option for the other vehicle kind)
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--segment-m", "5",
                 "--duration-s", "1", "--out", str(tmp_path / "one")]) == 0
    out = capsys.readouterr().out
    assert "note: --segment-m 5 not used: one terrain (ICE) along the whole path" in out
    (run,) = read_runs_dir(tmp_path / "one")
    assert run.meta["segment_length_m"] == 5.0
    # a list naming one terrain twice is one terrain too
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE,ICE", "--segment-m", "5",
                 "--duration-s", "1", "--out", str(tmp_path / "twice")]) == 0
    assert "note: --segment-m 5 not used: one terrain (ICE)" in capsys.readouterr().out
    # left out, or with several terrains: no note; the default is still 25 m
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--duration-s", "1",
                 "--out", str(tmp_path / "default")]) == 0
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE,SNOW", "--segment-m", "5",
                 "--duration-s", "1", "--out", str(tmp_path / "two")]) == 0
    assert "--segment-m" not in capsys.readouterr().out.replace("(--segment-m)", "")
    (run,) = read_runs_dir(tmp_path / "default")
    assert run.meta["segment_length_m"] == 25.0


def test_a_full_terrain_folder_is_refused_before_simulating(tmp_path, monkeypatch, capsys):
    # the layout numbers a terrain folder's runs 00-99: with all of them taken, the run was
    # simulated (up to 2 h of simulated time) and only then refused by the writer
    import pipelines.simulate as simulate_command

    for name in ("ICE", "MIXED"):
        folder = tmp_path / name
        folder.mkdir()
        for i in range(100):
            (folder / f"imu_{i:02d}.csv").touch()
    simulated = []
    monkeypatch.setattr(simulate_command, "simulate", lambda config: simulated.append(config))
    # a list of one terrain is that terrain's run (folder ICE), as --terrain ICE
    for terrain, folder in (("ICE", "ICE"), ("ICE,SNOW", "MIXED"), ("ICE,ICE", "ICE")):
        assert main(["simulate", "--vehicle", "husky", "--terrain", terrain, "--duration-s",
                     "1", "--out", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert (f"terrain simulate: error: {tmp_path / folder} already holds runs 00-99" in err)
    assert not simulated


def test_runs_of_one_terrain_and_seed_in_two_scenarios_have_two_ids():
    """A simulated run was sim/<TERRAIN>/<seed> whatever its scenario, so a spin and a
    straight run of one terrain and seed were one run to everything that groups or counts
    windows by run id (run-grouped folds among them)."""
    ids = {simulate(SimConfig(vehicle="husky", terrains=("GRASS",), scenario=scenario,
                              duration_s=0.5, seed=3)).run_id
           for scenario in ("spin", "straight_accel")}
    assert ids == {"sim/GRASS/spin/3", "sim/GRASS/straight_accel/3"}
