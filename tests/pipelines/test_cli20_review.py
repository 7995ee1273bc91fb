"""Review of the command line (cli20): option values that name a file where a folder is
read, and other inputs answered in one line naming what is wrong."""

from __future__ import annotations

import argparse
import math

import pytest
from cli_helpers import exit_code
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import DataFormatError
from terrain.io.shipped import default_data_dir, read_manifest


@pytest.mark.parametrize("name", ["manifest.json", "notes.txt"])
def test_slip_table_data_dir_naming_a_file_says_it_is_a_file(name, tmp_path, capsys):
    # --data-dir data/manifest.json (the manifest itself) was answered "manifest not found
    # (file data/manifest.json/manifest.json)", as if the manifest were missing
    given = tmp_path / name
    given.write_bytes((default_data_dir() / "manifest.json").read_bytes())
    assert exit_code(["slip-table", "--data-dir", str(given)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
    assert "is a file" in err[0] and "not found" not in err[0]
    assert f"{given}/manifest.json" not in err[0] and str(given) in err[0]


def test_read_manifest_of_a_file_raises_the_typed_error_naming_it(tmp_path):
    given = tmp_path / "manifest.json"
    given.write_text("{}")
    with pytest.raises(DataFormatError, match="is a file") as exc:
        read_manifest(given)
    assert str(exc.value.path) == str(given)


@pytest.mark.parametrize("window", ["0.03", "1e-9"])
def test_cv_window_too_short_says_the_window_and_rate_given(window, capsys):
    # "a window must hold at least 4 samples" named neither the --window-s given nor the
    # rate, where a window too long is answered with both
    assert exit_code(["cv", "--dataset", "borealtc", "--window-s", window]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "at least 4 samples" in err[0]
    assert f"a window of {float(window):g} s at 100 Hz" in err[0]


@pytest.mark.parametrize("uri", ["s3://bucket/slip/artifacts", "https://host/models/slip",
                                 "models:/slip-husky/2"])
def test_estimate_hands_a_slip_model_uri_to_mlflow_as_given(uri, tmp_path, monkeypatch,
                                                            capsys):
    # --slip-model-dir takes "MLflow model dir or model URI": read as a path, the URI lost
    # a slash of its '//' (s3:/bucket/..., https:/host/...), which no store resolves
    import mlflow.sklearn

    from terrain.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--scenario",
                 "straight_accel", "--duration-s", "1", "--out", "runs"]) == 0
    asked = []

    def load_model(model_uri, *args, **kwargs):
        asked.append(model_uri)
        raise OSError("no store here")

    monkeypatch.setattr(mlflow.sklearn, "load_model", load_model)
    assert exit_code(["estimate", "runs", "--out", "e.csv", "--slip-model-dir", uri]) == 2
    assert asked == [uri]
    assert f"--slip-model-dir {uri}: the model cannot be loaded" in capsys.readouterr().err


def _number_types():
    import pipelines.arguments as arguments
    from pipelines.audit import _min_gain
    from pipelines.compare import _n_jobs

    return [arguments.positive_number, arguments.non_negative_number,
            arguments.sim_duration_s, arguments.probability, arguments.positive_integer,
            arguments.integer_up_to(10), arguments.integer_in(0, 100), arguments.seed_value,
            _min_gain, _n_jobs, arguments.terrain_name]


_OPTION_TEXTS = st.one_of(
    st.text(max_size=12), st.floats().map(repr), st.integers().map(str),
    st.sampled_from(["nan", "-nan", "inf", "-inf", "1e400", "-1e400", "-0", "0x1", "1_0",
                     " 3 ", "+5", "True", "", " "]))


@settings(max_examples=300, deadline=None)
@given(_OPTION_TEXTS)
def test_every_option_type_gives_a_finite_value_in_range_or_a_usage_error(text):
    # whatever the shell hands over: the value the type checks, or argparse's one-line
    # usage error; never another exception (a traceback) nor a non-finite number
    for parse in _number_types():
        try:
            value = parse(text)
        except argparse.ArgumentTypeError:
            continue
        if isinstance(value, float):
            assert math.isfinite(value), (parse.__name__, text, value)
        if parse.__name__ == "probability":
            assert 0 <= value <= 1
        elif parse.__name__ in ("positive_number", "sim_duration_s", "positive_integer"):
            assert value > 0
        elif parse.__name__ == "non_negative_number":
            assert value >= 0


@pytest.mark.parametrize("json_name", ["r_figures", "./r_figures", "ABSOLUTE"])
def test_audit_refuses_a_json_file_where_the_markdown_puts_its_figures(
        json_name, tmp_path, monkeypatch, capsys):
    # --json r_figures --md r.md: the JSON was written as the file r_figures, and the
    # Markdown's figures folder r_figures/ then failed ('File exists: r_figures') after the
    # whole audit had run (minutes), leaving no Markdown
    import pipelines.audit as audit

    def read_runs_dir(*args, **kwargs):
        raise AssertionError("runs read before the outputs were checked")

    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs").mkdir()
    monkeypatch.setattr(audit, "read_runs_dir", read_runs_dir)
    if json_name == "ABSOLUTE":     # the same file, named another way
        json_name = str(tmp_path / "r_figures")
    assert exit_code(["audit", "runs", "--json", json_name, "--md", "r.md",
                      "--no-mlflow"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--json" in err[0] and "--md" in err[0]
    assert "r_figures" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs"]


def test_compare_leaves_no_grid_figure_of_an_earlier_grid_in_its_folder(tmp_path, monkeypatch):
    # a grid over one signal set and one window writes no compare_grid.png / .md: those of
    # an earlier, larger grid in the same --out stayed there beside the new table, as if
    # this run's
    import matplotlib.pyplot as plt
    import pandas as pd
    from cli_helpers import RecordingRun

    import pipelines.compare as compare
    from terrain.cli import main

    monkeypatch.chdir(tmp_path)     # the tracking store, if any, is created there
    out = tmp_path / "cmp"
    out.mkdir()
    for name in ("compare_grid.png", "compare_grid.md"):
        (out / name).write_text("an earlier grid")
    cell = {"rows": [{"model": "svm", "accuracy": 0.5}],
            "predictions": pd.DataFrame({"run": ["r"], "predicted": ["ICE"]})}
    monkeypatch.setattr(compare, "tracked_run", RecordingRun())
    monkeypatch.setattr(compare, "iter_grid", lambda config, n_jobs: iter([cell]))
    monkeypatch.setattr(compare, "log_cell", lambda result: None)
    monkeypatch.setattr(compare, "summary_table", lambda rows: rows)
    monkeypatch.setattr(compare, "markdown_table", lambda table: "| table |")
    monkeypatch.setattr(compare, "plot_comparison", lambda table: plt.figure())
    monkeypatch.setattr(compare, "spans_grid", lambda table: False)
    assert main(["compare", "--models", "svm", "--datasets", "vulpi", "--signals", "all",
                 "--windows-s", "2", "--seeds", "0", "--n-jobs", "1", "--no-progress",
                 "--out", str(out)]) == 0
    plt.close("all")
    assert (out / "compare_table.md").read_text() == "| table |"
    assert not (out / "compare_grid.png").exists() and not (out / "compare_grid.md").exists()
