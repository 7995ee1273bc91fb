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
