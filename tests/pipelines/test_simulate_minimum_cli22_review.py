"""Boundaries of ``terrain simulate --duration-s``: the shortest duration its help states
per vehicle is the simulator's minimum, taken; one physics step less is refused
(cli22 review)."""

from __future__ import annotations

import argparse

import pandas as pd
import pytest

import pipelines.simulate as simulate_cli
from terrain.cli import main
from terrain.sim.simulate import minimum_duration_s

STATED = {"husky": 0.16, "tracked": 0.1, "agrimaro": 0.04}


def test_the_help_states_each_vehicles_minimum():
    parser = argparse.ArgumentParser()
    simulate_cli.add_arguments(parser)
    text = next(a.help for a in parser._actions if a.dest == "duration_s")
    for vehicle, minimum in STATED.items():
        assert minimum_duration_s(vehicle)[0] == pytest.approx(minimum, abs=1e-12)
        assert f"{vehicle} {minimum:g}" in text


@pytest.mark.parametrize("vehicle", sorted(STATED))
def test_the_stated_minimum_writes_two_samples_of_every_stream_and_one_step_less_is_refused(
        vehicle, tmp_path, capsys):
    minimum = STATED[vehicle]
    assert main(["simulate", "--vehicle", vehicle, "--terrain", "ICE", "--duration-s",
                 f"{minimum:g}", "--out", str(tmp_path / "ok")]) == 0
    files = sorted((tmp_path / "ok" / "ICE").glob("*_00.csv"))
    assert files and min(len(pd.read_csv(f)) for f in files) >= 2
    less = f"{minimum - 0.01:g}"                     # one 100 Hz physics step less
    assert main(["simulate", "--vehicle", vehicle, "--terrain", "ICE", "--duration-s", less,
                 "--out", str(tmp_path / "short")]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"the minimum is {minimum:g} s" in err and not (tmp_path / "short").exists()
