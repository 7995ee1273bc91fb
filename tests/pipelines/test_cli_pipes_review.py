"""Third review of the command-line layer (arguments, dispatch, estimate, serve, the closed
loop's classifier options): odd inputs and hand mutants no earlier test held."""

from __future__ import annotations

import argparse

import pytest
from cli_helpers import exit_code

from pipelines.arguments import output_dir, output_file


@pytest.mark.parametrize("name", ["loop", "loop/out.csv"])
def test_an_output_path_through_a_symlink_loop_is_refused_in_one_line(
        name, tmp_path, monkeypatch, capsys):
    # `--out loop` (a link to itself) passed the output check, then Path.resolve raised
    # RuntimeError('Symlink loop') while the options were read: a traceback
    monkeypatch.chdir(tmp_path)
    (tmp_path / "loop").symlink_to("loop")
    with pytest.raises(argparse.ArgumentTypeError, match="symbolic links"):
        output_file(name)
    with pytest.raises(argparse.ArgumentTypeError, match="symbolic links"):
        output_dir(name)
    assert exit_code(["estimate", "runs", "--out", name]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "RuntimeError" not in err
    assert f"argument --out: cannot write {name!r}: " in err.splitlines()[-1]


def test_ctrl_c_while_the_commands_are_loaded_is_one_line_with_status_130(monkeypatch,
                                                                          capsys):
    # loading the pipelines takes seconds; a Ctrl-C then was a traceback of import frames
    import terrain.cli as cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert cli.main(["slip-table"]) == 130
    assert capsys.readouterr().err == "terrain: interrupted\n"


def test_the_entry_points_module_leaves_the_slow_imports_to_main():
    # the console script imports terrain.cli before main can catch a Ctrl-C: that import
    # must not load the pipelines, MLflow or scikit-learn (seconds of imports)
    import subprocess
    import sys

    code = ("import sys, terrain.cli; print(sorted(m for m in ('pipelines.arguments', "
            "'terrain.tracking', 'mlflow', 'sklearn') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"
