"""Output options are checked while the options are read, before any work is done."""

from __future__ import annotations

import argparse
import os

import pytest
from cli_helpers import exit_code

from pipelines.arguments import EMPTY_PATH, input_path, model_dir, output_dir, output_file
from terrain.cli import build_parser, main


@pytest.fixture
def blocker(tmp_path):
    """A plain file where a folder would have to be."""
    path = tmp_path / "afile"
    path.write_text("x")
    return path


def test_output_file_accepts_new_paths_under_missing_folders(tmp_path):
    target = tmp_path / "a" / "b" / "out.csv"
    assert output_file(str(target)) == target
    existing = tmp_path / "old.csv"
    existing.write_text("x")
    assert output_file(str(existing)) == existing


def test_output_file_refuses_a_file_as_folder_at_any_depth(blocker):
    for target in (blocker / "out.csv", blocker / "deeper" / "out.csv"):
        with pytest.raises(argparse.ArgumentTypeError, match="is a file, not a folder"):
            output_file(str(target))


def test_output_file_refuses_a_folder(tmp_path):
    with pytest.raises(argparse.ArgumentTypeError, match="it is a folder"):
        output_file(str(tmp_path))


def test_output_dir_refuses_a_file_itself_or_above(blocker, tmp_path):
    for target in (blocker, blocker / "sub"):
        with pytest.raises(argparse.ArgumentTypeError, match="is a file"):
            output_dir(str(target))
    assert output_dir(str(tmp_path / "new" / "deep")) == tmp_path / "new" / "deep"


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_unwritable_folder_refused(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(argparse.ArgumentTypeError, match="no write permission"):
            output_file(str(locked / "out.csv"))
        with pytest.raises(argparse.ArgumentTypeError, match="no write permission"):
            output_dir(str(locked / "sub"))
    finally:
        locked.chmod(0o700)


def test_unwritable_folder_refused_whatever_the_user(tmp_path, monkeypatch):
    # root writes anywhere (CI runs as root), so the permission is denied by os.access, the
    # call pipelines.arguments asks
    import pipelines.arguments as arguments
    locked = tmp_path / "locked"
    locked.mkdir()
    (locked / "old.csv").write_text("x")
    real_access = os.access
    asked = []

    def access(path, mode, *args, **kwargs):
        path = os.path.abspath(path)
        asked.append(path)
        if path == str(locked) or path.startswith(str(locked) + os.sep):
            return False
        return real_access(path, mode, *args, **kwargs)

    monkeypatch.setattr(arguments.os, "access", access)
    for target in (locked / "out.csv", locked / "new" / "out.csv", locked / "old.csv"):
        with pytest.raises(argparse.ArgumentTypeError, match="no write permission"):
            output_file(str(target))
    for target in (locked, locked / "sub", locked / "sub" / "deeper"):
        with pytest.raises(argparse.ArgumentTypeError, match="no write permission"):
            output_dir(str(target))
    with pytest.raises(argparse.ArgumentTypeError, match="no write permission"):
        model_dir(str(locked / "m"))
    assert asked                                   # the branch was reached through os.access
    assert output_file(str(tmp_path / "free" / "out.csv")) == tmp_path / "free" / "out.csv"
    assert output_dir(str(tmp_path / "free")) == tmp_path / "free"


def test_model_dir_refuses_a_non_empty_folder(tmp_path):
    assert model_dir(str(tmp_path / "m")) == tmp_path / "m"
    (tmp_path / "empty").mkdir()
    assert model_dir(str(tmp_path / "empty")) == tmp_path / "empty"
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "MLmodel").write_text("x")
    with pytest.raises(argparse.ArgumentTypeError, match="not empty"):
        model_dir(str(tmp_path / "full"))


#: every output option of the CLI, as (argv without the output, the output option)
_OUTPUT_OPTIONS = [
    (["predict", "--model", "M", "RUNS"], "--out", "file"),
    (["estimate", "RUNS"], "--out", "file"),
    (["stream", "--model", "M", "RUN"], "--out", "file"),
    (["cv", "--dataset", "vulpi"], "--json", "file"),
    (["audit", "--dataset", "borealtc"], "--json", "file"),
    (["audit", "--dataset", "borealtc", "--json", "ok.json"], "--md", "file"),
    (["control-sim", "--terrain", "ICE"], "--json", "file"),
    (["control-sim", "--terrain", "ICE", "--json", "ok.json"], "--csv", "file"),
    (["validate", "sim"], "--out", "file"),
    (["compare"], "--out", "dir"),
    (["control-grid"], "--out", "dir"),
    (["simulate"], "--out", "dir"),
    (["slip-fit"], "--out", "dir"),
    (["stream-eval"], "--model-out", "dir"),
    (["train", "--dataset", "vulpi"], "--model-out", "dir"),
    (["serve", "--model", "M"], "--served-out", "dir"),
    (["convert", "SRC", "--dataset", "vulpi"], "--data-dir", "dir"),
]


@pytest.mark.parametrize("argv, option, kind", _OUTPUT_OPTIONS,
                         ids=[f"{a[0]} {o}" for a, o, _ in _OUTPUT_OPTIONS])
def test_cli_refuses_unwritable_output_before_any_work(argv, option, kind, blocker,
                                                       monkeypatch, capsys):
    """A file in the output's path is a one-line usage error (exit 2) naming the option,
    from the parser itself: no run is read, no model trained, no MLflow run opened."""
    parser = build_parser()
    sub = parser._subparsers._group_actions[0].choices[argv[0]]
    assert any(option in a.option_strings for a in sub._actions), (argv[0], option)
    monkeypatch.chdir(blocker.parent)
    target = "afile/out.csv" if kind == "file" else "afile/sub"
    with pytest.raises(SystemExit) as exc:
        main([*argv, option, target])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}: cannot" in err and "'afile'" in err
    assert "Traceback" not in err
    assert not (blocker.parent / "mlflow.db").exists() and not (blocker.parent / "mlruns").exists()


def test_empty_output_path_refused():
    # Path("") is the working folder: `simulate --out ""` wrote into it without a word
    # one wording for every path option: `--model ""` and `--data-dir ""` were told
    # "give one, or leave the option out for its default" and "give a folder name"
    for check in (output_file, output_dir, model_dir, input_path):
        for value in ("", "  "):
            with pytest.raises(argparse.ArgumentTypeError) as exc:
                check(value)
            assert str(exc.value) == EMPTY_PATH == (
                "an empty path (give a path, or leave the option out where it has a default)")


def test_convert_refuses_an_empty_data_dir_instead_of_the_shipped_one(tmp_path, monkeypatch,
                                                                      capsys):
    # `--data-dir ""` (an unset shell variable) fell back to the default data/ folder and
    # overwrote the shipped data there with the converted runs
    monkeypatch.setenv("TERRAIN_DATA_DIR", str(tmp_path / "shipped"))
    with pytest.raises(SystemExit) as exc:
        main(["convert", str(tmp_path / "src"), "--dataset", "vulpi", "--data-dir", ""])
    assert exc.value.code == 2
    assert f"argument --data-dir: {EMPTY_PATH}" in capsys.readouterr().err
    assert not (tmp_path / "shipped").exists()


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
def test_a_folder_where_nothing_can_be_created_is_refused_even_for_root(tmp_path):
    # os.access says yes to root in /proc; the scratch file tells the truth
    for check, target in ((output_file, "/proc/terrain-out.csv"),
                          (output_dir, "/proc/terrain-out"), (model_dir, "/proc/m")):
        with pytest.raises(argparse.ArgumentTypeError, match="cannot create a file in '/proc'"):
            check(target)
    # the scratch file of a writable folder is removed again
    assert output_file(str(tmp_path / "new.csv")) == tmp_path / "new.csv"
    assert output_dir(str(tmp_path / "sub")) == tmp_path / "sub"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
@pytest.mark.parametrize("argv, option, kind", _OUTPUT_OPTIONS,
                         ids=[f"{a[0]} {o}" for a, o, _ in _OUTPUT_OPTIONS])
def test_cli_refuses_an_output_under_proc_before_any_work(argv, option, kind, tmp_path,
                                                          monkeypatch, capsys):
    """`cv --json /proc/x.json` ran the whole CV before failing (found by a CLI fuzz)."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main([*argv, option, "/proc/terrain-out" + (".csv" if kind == "file" else "")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}: cannot" in err and "'/proc'" in err
    assert "Traceback" not in err and list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs Linux's /dev/full")
def test_a_full_disk_is_reported_naming_the_output_option(tmp_path, capsys):
    # Python's ENOSPC carries no file name: the one line said "[Errno 28] No space left on
    # device" and nothing about which output
    run_dir = tmp_path / "sim"
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--duration-s", "3",
                 "--out", str(run_dir)]) == 0
    capsys.readouterr()
    assert main(["estimate", "--out", "/dev/full", str(run_dir)]) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith("terrain estimate: error: ")
    assert "No space left on device while writing --out /dev/full" in line


def test_two_outputs_naming_one_file_are_refused_before_any_work(tmp_path, monkeypatch,
                                                                 capsys):
    # `audit --json r.json --md r.json` ran the whole audit, wrote the Markdown over the
    # JSON and said "report written to r.json and r.json"
    monkeypatch.chdir(tmp_path)
    for argv in (["audit", "--dataset", "vulpi", "--json", "r.json", "--md", "./r.json"],
                 ["control-sim", "--vehicle", "husky", "--terrain", "ICE", "--scenario",
                  "straight_accel", "--controller", "off", "--json", "r.json", "--csv",
                  "r.json"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err
        assert err.strip().splitlines()[-1].endswith(
            "'r.json' is the file of --json too (give each output its own file)")
    assert list(tmp_path.iterdir()) == []


def _runs_folder(root):
    folder = root / "runs" / "ICE"
    folder.mkdir(parents=True)
    for name in ("imu_00.csv", "pro_00.csv", "meta_00.json"):
        (folder / name).write_text("kept\n")
    model = root / "model"
    model.mkdir()
    (model / "MLmodel").write_text("kept\n")
    return root / "runs"


@pytest.mark.parametrize("argv, target", [
    (["predict", "--model", "model", "runs"], "runs/ICE/pro_00.csv"),
    (["predict", "--model", "model", "runs"], "runs/ICE/imu_07.csv"),
    (["estimate", "runs/ICE"], "runs/ICE/meta_00.json"),
    (["stream", "--model", "model", "runs/ICE"], "runs/ICE/imu_00.csv"),
    (["stream", "--model", "model", "runs/ICE"], "model/MLmodel"),
])
def test_an_output_among_the_input_files_is_refused_before_any_work(argv, target, tmp_path,
                                                                    monkeypatch, capsys):
    # `predict --model M runs --out runs/ICE/pro_00.csv` read the run, then wrote the
    # predictions over its wheel file: the measured data was lost and the next read failed
    runs = _runs_folder(tmp_path)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--out", target])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument --out: cannot write {target!r}: " in err and "Traceback" not in err
    assert all(f.read_text() == "kept\n" for f in (runs / "ICE").iterdir())
    assert not (tmp_path / "mlflow.db").exists()


def test_an_output_beside_the_input_files_is_taken(tmp_path, monkeypatch):
    # a file the readers do not read may be written inside the runs folder (and rewritten)
    _runs_folder(tmp_path)
    monkeypatch.chdir(tmp_path)
    for target in ("runs/predictions.csv", "runs/ICE/predictions.csv"):
        (tmp_path / target).write_text("old\n")
        args = build_parser().parse_args(["predict", "--model", "model", "runs",
                                          "--out", target])
        assert str(args.out) == target


@pytest.mark.slow
def test_estimate_checks_each_per_run_file_before_any_work(tmp_path, capsys):
    # with several runs, estimate writes <stem>_<TERRAIN>_<XX><suffix> beside --out, files the
    # output checks never saw: '--out runs/ICE/meta.json' planted meta_ICE_00.json and
    # meta_SNOW_00.json among the run files (the next read: 'run has no wheel file'), and a
    # per-run name that was a folder failed after the earlier runs had been estimated
    runs = tmp_path / "runs"
    for terrain in ("ICE", "SNOW"):
        assert main(["simulate", "--vehicle", "husky", "--terrain", terrain, "--duration-s",
                     "2", "--out", str(runs)]) == 0
    before = sorted(runs.rglob("*"))
    capsys.readouterr()
    out = runs / "ICE" / "meta.json"
    assert main(["estimate", str(runs), "--out", str(out), "--slip-model", "ekf"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err == (f"terrain estimate: error: --out: cannot write "
                   f"{str(runs / 'ICE' / 'meta_ICE_00.json')!r}: it is named like a run file "
                   f"of the input runs folder {str(runs)!r} (write the output elsewhere)")
    assert sorted(runs.rglob("*")) == before
    (tmp_path / "est_SNOW_00.csv").mkdir()
    assert main(["estimate", str(runs), "--out", str(tmp_path / "est.csv"),
                 "--slip-model", "ekf"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err == (f"terrain estimate: error: --out: cannot write "
                   f"{str(tmp_path / 'est_SNOW_00.csv')!r}: it is a folder (give a file name)")
    assert not (tmp_path / "est_ICE_00.csv").exists()


_LONG = "a" * 300   # one name longer than any file system takes (ENAMETOOLONG)


@pytest.mark.parametrize("argv", [
    ["predict", "--model", "m", "r", "--out", f"{_LONG}.csv"],      # output file
    ["predict", "--model", "m", "r", "--out", f"{_LONG}/p.csv"],    # its folder
    ["simulate", "--vehicle", "husky", "--terrain", "ICE", "--out", _LONG],  # output folder
    ["estimate", _LONG, "--out", "e.csv"],                          # an input
], ids=["file", "file-folder", "folder", "input"])
def test_a_name_too_long_is_one_line_not_a_traceback(argv, tmp_path, monkeypatch, capsys):
    # Path.exists() raises OSError [Errno 36] File name too long: it escaped argparse (and
    # the input check run before the command) as a Python traceback, exit 1
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m").mkdir()
    (tmp_path / "r").mkdir()
    code = exit_code(argv)
    assert code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith(f"terrain {argv[0]}: error:")
    assert "too long" in err
