"""Runs folders whose names are not UTF-8 on disk."""

from __future__ import annotations

import os

from terrain.cli import main
from terrain.io.measured import folder_text, read_folder_run, read_runs_path
from terrain.io.report import input_report
from terrain.io.writer import write_run
from terrain.sim import SimConfig, simulate


def test_a_runs_folder_named_in_other_bytes_than_utf8_is_read_and_reported(tmp_path, capsys):
    # 'sim\xff' (a Latin-1 name) came from the file system with a lone surrogate, which the
    # input report's text column could not encode: every command reading it ended in
    # "internal error: UnicodeEncodeError ... surrogates not allowed"
    root = tmp_path / os.fsdecode(b"sim\xff")
    write_run(simulate(SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="random",
                                 duration_s=3.0, seed=2)), root)
    os.rename(root / "ASPHALT", root / os.fsdecode(b"ASPH\xe4LT"))
    run, = read_runs_path(root)
    assert run.run_id == "sim\\xff/ASPH\\xe4LT/00" and run.terrain == "ASPH\\XE4LT"
    assert run.run_id.encode("utf-8")       # text every later step can hold
    assert "sim\\xff/ASPH\\xe4LT/00" in input_report([run]).text()
    assert read_folder_run(root / os.fsdecode(b"ASPH\xe4LT")).run_id == "ASPH\\xe4LT/00"
    assert main(["estimate", str(root), "--out", str(tmp_path / "s.csv"),
                 "--slip-model", "ekf"]) == 0
    assert "sim\\xff/ASPH\\xe4LT/00 (husky)" in capsys.readouterr().out


def test_folder_text_keeps_every_decodable_name():
    for name in ("SNOW", "schnée", "雪", "a b", ""):
        assert folder_text(name) == name
    assert folder_text(os.fsdecode(b"\xff\xfeX")) == "\\xff\\xfeX"
