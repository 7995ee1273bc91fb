"""Two ``terrain simulate`` commands writing one ``--out`` folder at once (cli25): both took
the first free run number and wrote run 00 through the same temporary names, so one
simulation was lost (or its files mixed with the other's) while both said ``run 00``."""

from __future__ import annotations

import threading
import time

import pandas as pd
import pytest

from pipelines import simulate as simulate_command
from terrain.cli import build_parser
from terrain.io.measured import read_runs_path
from terrain.sim.simulate import SimConfig, simulate


@pytest.mark.slow
def test_two_simulate_commands_into_one_folder_at_once_write_two_runs(
        tmp_path, monkeypatch, capsys):
    runs = {seed: simulate(SimConfig(vehicle="husky", terrains=("ICE",),
                                     scenario="straight_accel", duration_s=2.0, seed=seed))
            for seed in (1, 2)}
    monkeypatch.setattr(simulate_command, "simulate", lambda config: runs[config.seed])
    real = pd.DataFrame.to_csv

    def slow(self, *args, **kwargs):    # widens the window between choosing and writing
        time.sleep(0.02)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(pd.DataFrame, "to_csv", slow)
    parser = build_parser()
    barrier = threading.Barrier(2)
    errors = []

    def command(seed):
        args = parser.parse_args(["simulate", "--vehicle", "husky", "--terrain", "ICE",
                                  "--scenario", "straight_accel", "--duration-s", "2",
                                  "--seed", str(seed), "--out", str(tmp_path)])
        barrier.wait()
        try:
            args._main(args)
        except BaseException as exc:  # noqa: B902 - reported by the test
            errors.append(exc)

    threads = [threading.Thread(target=command, args=(seed,)) for seed in (1, 2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    monkeypatch.undo()
    assert not errors, errors
    out = capsys.readouterr().out
    assert "(run 00)" in out and "(run 01)" in out, out
    names = sorted(p.name for p in (tmp_path / "ICE").iterdir())
    assert not [n for n in names if n.startswith(".")], names
    read = read_runs_path(tmp_path)
    assert len(read) == 2
    seeds = sorted(int(r.meta["seed"]) for r in read)
    assert seeds == [1, 2]
