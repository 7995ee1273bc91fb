"""The option types take the ends of their documented ranges and refuse the next value, and
an output option is refused where it is the very file an input option names."""

from __future__ import annotations

import argparse

import pytest

from pipelines.arguments import (integer_in, integer_up_to, non_negative_number,
                                 probability, sim_duration_s)
from terrain.audit.selection import MAX_BOOTSTRAP, MIN_BOOTSTRAP
from terrain.cli import main
from terrain.models.registry import MAX_CNN_SEEDS
from terrain.sim.simulate import MAX_DURATION_S


def test_sim_duration_takes_its_maximum_and_refuses_more():
    # (0, MAX_DURATION_S] s: the documented maximum itself is a valid duration
    assert sim_duration_s(f"{MAX_DURATION_S:g}") == MAX_DURATION_S
    with pytest.raises(argparse.ArgumentTypeError,
                       match=rf"must be a finite number in \(0, {MAX_DURATION_S:g}\] s, got "):
        sim_duration_s(f"{MAX_DURATION_S + 0.5:g}")


def test_probability_takes_both_ends_and_refuses_beyond_them():
    # [0, 1] closed (--min-confidence 1: only certain windows); NaN is no probability
    assert probability("0") == 0.0 and probability("1") == 1.0
    for value in ("-1e-9", "1.000001", "nan"):
        with pytest.raises(argparse.ArgumentTypeError, match="must be a probability in"):
            probability(value)


def test_non_negative_number_takes_zero_and_refuses_infinity():
    # a controller gain: 0 switches the term off; inf is no gain
    assert non_negative_number("0") == 0.0
    for value in ("inf", "-1e-9", "nan"):
        with pytest.raises(argparse.ArgumentTypeError, match="must be a finite number >= 0"):
            non_negative_number(value)


def test_integer_up_to_takes_its_maximum_and_refuses_one_more():
    parse = integer_up_to(MAX_CNN_SEEDS)
    assert parse("1") == 1 and parse(str(MAX_CNN_SEEDS)) == MAX_CNN_SEEDS
    with pytest.raises(argparse.ArgumentTypeError,
                       match=f"must be an integer in 1-{MAX_CNN_SEEDS}, got {MAX_CNN_SEEDS + 1}"):
        parse(str(MAX_CNN_SEEDS + 1))


def test_integer_in_takes_both_ends_and_refuses_one_past_each():
    parse = integer_in(MIN_BOOTSTRAP, MAX_BOOTSTRAP)
    assert parse(str(MIN_BOOTSTRAP)) == MIN_BOOTSTRAP
    assert parse(str(MAX_BOOTSTRAP)) == MAX_BOOTSTRAP
    for bad in (MIN_BOOTSTRAP - 1, MAX_BOOTSTRAP + 1):
        with pytest.raises(argparse.ArgumentTypeError,
                           match=f"must be an integer in {MIN_BOOTSTRAP}-{MAX_BOOTSTRAP:,}, "
                                 f"got {bad}$"):
            parse(str(bad))
    assert integer_in(0, 3)("0") == 0


def test_an_output_that_is_the_input_file_is_refused_before_any_work(tmp_path, monkeypatch,
                                                                     capsys):
    # `predict --model m.bin ... --out m.bin`: the model file given as input is the output
    (tmp_path / "runs").mkdir()
    (tmp_path / "m.bin").write_text("kept\n")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(["predict", "--model", "m.bin", "runs", "--out", "m.bin"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert ("argument --out: cannot write 'm.bin': it is an input of this command" in err
            and "Traceback" not in err)
    assert (tmp_path / "m.bin").read_text() == "kept\n"
