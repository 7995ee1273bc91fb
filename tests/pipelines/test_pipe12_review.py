"""Review pipe12 of the command-line layer: option values at their bounds, outputs against
inputs, exit codes."""

from __future__ import annotations

from pipelines.arguments import check_output_files
from terrain.cli import _command_parser, build_parser


def _parsed(argv):
    """The sub-command parser and parsed options of ``terrain ARGV``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return _command_parser(parser, args), args


def test_a_choice_is_not_taken_for_an_input_file_of_that_name(tmp_path, monkeypatch):
    # ``--lag none`` is a choice, not a path: a file 'none' in the working folder (an
    # earlier --out none) is an output the command may write again, not an input it reads
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs").mkdir()
    (tmp_path / "none").write_text("t_s\n")
    check_output_files(*_parsed(["estimate", "runs", "--lag", "none", "--out", "none"]))


def test_a_wheel_only_run_is_said_to_have_no_gyro_observing_its_slip(tmp_path, capsys):
    # without an IMU no gyro observes the yaw rate: slip_* and gyro_bias are the filter's
    # prediction from the wheel speeds alone; with --slip-model ekf nothing said so before
    from terrain.cli import main
    from terrain.io.writer import write_run
    from terrain.sim import SimConfig, simulate

    run = simulate(SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="random",
                             duration_s=5.0, seed=1))
    write_run(run, tmp_path / "runs")
    (tmp_path / "runs" / "ASPHALT" / "imu_00.csv").unlink()
    assert main(["estimate", str(tmp_path / "runs"), "--out", str(tmp_path / "e.csv"),
                 "--slip-model", "ekf"]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if "no IMU" in line]
    assert len(notes) == 1 and "ASPHALT/00" in notes[0] and "gyro" in notes[0]
