"""Model comparison grid: history decisions, the --quick CLI run, the Dask backend."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from terrain.cli import main
from terrain.errors import ConfigError
from terrain.models.compare import (CompareConfig, history_predictions, joblib_backend,
                                    run_grid)


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """Run commands in an empty folder with the embedded MLflow store."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


def test_history_averages_only_earlier_windows_of_the_same_run():
    # run r1: A, A, B(weak); run r2 starts with a B window that must not see r1's history
    pred = pd.DataFrame({"group": ["r1", "r1", "r1", "r2"],
                         "t_start_s": [0.0, 2.0, 4.0, 0.0],
                         "proba_A": [0.9, 0.8, 0.4, 0.1],
                         "proba_B": [0.1, 0.2, 0.6, 0.9]})
    shuffled = pred.iloc[[3, 1, 2, 0]]
    np.testing.assert_array_equal(history_predictions(shuffled, ["A", "B"], 1),
                                  ["B", "A", "B", "A"])
    # k=3 at the third window of r1: mean A = 0.7 -> A; r2 keeps its own B
    np.testing.assert_array_equal(history_predictions(shuffled, ["A", "B"], 3),
                                  ["B", "A", "A", "A"])


def test_history_gives_one_decision_per_row_of_a_frame_with_a_repeated_index():
    # two folds' frames joined by pd.concat keep their own 0, 1 index: each label was looked
    # up by index, so the 4 rows got 8 decisions, r2's rows those of r1's as well
    first = pd.DataFrame({"group": ["r1", "r1"], "t_start_s": [0.0, 2.0],
                          "proba_A": [0.9, 0.2], "proba_B": [0.1, 0.8]})
    second = pd.DataFrame({"group": ["r2", "r2"], "t_start_s": [0.0, 2.0],
                           "proba_A": [0.1, 0.7], "proba_B": [0.9, 0.3]})
    joined = pd.concat([first, second])
    np.testing.assert_array_equal(history_predictions(joined, ["A", "B"], 1),
                                  ["A", "B", "B", "A"])
    # k = 2 at r2's second window: mean A 0.4 -> B (its own history, not r1's)
    np.testing.assert_array_equal(history_predictions(joined, ["A", "B"], 2),
                                  ["A", "A", "B", "B"])


def _history_frame():
    """Out-of-fold rows of one seed: run r1 (truth A), run r4 cut into two time blocks (truth
    B, the later block in its own split unit) and run r5 (truth A); given newest first."""
    rows = [("r1", "r1", t, pa, "A")
            for t, pa in zip((0.0, 2.0, 4.0, 6.0), (0.9, 0.9, 0.45, 0.1))]
    rows += [("r4@block0", "r4", 0.0, 0.9, "B"), ("r4@block0", "r4", 2.0, 0.9, "B"),
             ("r4@block1", "r4", 4.0, 0.45, "B")]
    rows += [("r5", "r5", t, pa, "A") for t, pa in zip((0.0, 2.0, 4.0), (0.9, 0.45, 0.45))]
    frame = pd.DataFrame(rows, columns=["group", "run", "t_start_s", "proba_A", "true"])
    frame["proba_B"] = 1.0 - frame["proba_A"]
    frame["predicted"] = np.where(frame["proba_A"] > 0.5, "A", "B")
    return frame.iloc[::-1]


def test_history_is_causal_within_each_split_unit_whatever_the_row_order():
    frame = _history_frame()
    k3 = pd.Series(history_predictions(frame, ["A", "B"], 3), index=frame.index).sort_index()
    # r1 at 4 s: mean A of 0.9, 0.9, 0.45 (a centred mean, 0.48, would look at 6 s); r1 at
    # 6 s: 0.48 -> B (four windows, 0.59, would be A); r4@block1 starts its own history
    # (0.45 -> B; averaged with the block before it, or across units, it would be A);
    # r4@block0 at 0 s is A alone (0.48 -> B had r1's last windows leaked in)
    np.testing.assert_array_equal(k3, ["A", "A", "A", "B", "A", "A", "B", "A", "A", "A"])
    k1 = history_predictions(frame, ["A", "B"], 1)
    np.testing.assert_array_equal(k1, frame["predicted"])


def test_scores_at_a_history_length_use_its_decisions_and_vote_per_split_unit():
    from terrain.models.compare import score_rows

    frame = _history_frame()
    k1, k3 = score_rows(frame, ["A", "B"], (1, 3), {"model": "toy"})
    assert (k1["history"], k3["history"], k3["model"], k3["n_windows"]) == (1, 3, "toy", 10)
    # k = 1: right r1 0, 2 s; r4@block1; r5 0 s. Votes: r1 tie -> A (right), r4@block0 A,
    # r4@block1 B (right), r5 B
    assert k1["accuracy"] == pytest.approx(4 / 10)
    assert k1["run_vote_accuracy"] == pytest.approx(2 / 4)
    # k = 3: r1 A A A B, r4 A A B, r5 A A A; the four split units (not the three runs:
    # r4 as one run votes A, wrong, which would give 2 / 3) vote right but r4@block0
    assert k3["accuracy"] == pytest.approx(7 / 10)
    assert k3["balanced_accuracy"] == pytest.approx((6 / 7 + 1 / 3) / 2)
    # F1 of A: precision 6 / 8, recall 6 / 7 -> 0.8; of B: precision 1 / 2, recall 1 / 3 -> 0.4
    assert k3["macro_f1"] == pytest.approx((0.8 + 0.4) / 2)
    assert k3["run_vote_accuracy"] == pytest.approx(3 / 4)


def test_a_cell_cuts_a_single_run_class_into_time_blocks_as_terrain_cv_does(vulpi_runs):
    from features.windows import make_windows
    from terrain.models.compare import Cell, cell_windows
    from terrain.models.cv import grouped_units
    from terrain.models.experiment import ExperimentConfig

    cell_cut = cell_windows(Cell("svm", "wheels", 2.0, "vulpi", 0), 5)
    ws, labels, groups, training = cell_cut[:4]
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), window_s=2.0)
    cut, cut_labels, cut_groups, split, n_dropped = grouped_units(
        make_windows(vulpi_runs, ("wheels",), config.window_config()), 5)
    assert split == ["DIRT_ROAD"] and training is None
    # DIRT_ROAD's one run as 5 split units, so a fold testing one of them trains on others
    assert len(set(groups[labels == "DIRT_ROAD"])) == 5
    np.testing.assert_array_equal(groups, cut_groups)
    np.testing.assert_array_equal(ws.t_start_s, cut.t_start_s)
    # and the cut is reported, as terrain cv reports it (it was discarded)
    assert cell_cut.split_classes == ("DIRT_ROAD",) and cell_cut.n_dropped == n_dropped
    assert cell_cut.notes[0].startswith(
        "vulpi: class DIRT_ROAD has a single run: cut into 5 contiguous time block(s)")


def test_unknown_model_is_rejected():
    with pytest.raises(ConfigError, match="unknown model"):
        CompareConfig(models=("svm", "forest"))


def test_quick_compare_writes_table_figure_and_child_runs(workdir, capsys):
    import mlflow

    from terrain.tracking import activate_store

    out = workdir / "cmp"
    assert main(["compare", "--quick", "--n-jobs", "1", "--out", str(out)]) == 0
    table = pd.read_csv(out / "compare_table.csv")
    assert set(table["model"]) == {"svm", "cnn"} and set(table["history"]) == {1, 5, 10}
    assert (out / "compare.png").stat().st_size > 0
    assert "| vulpi | all | 2 | 2 | 10 | svm |" in (out / "compare_table.md").read_text()
    svm = table[table["model"] == "svm"].set_index("history")
    assert svm.loc[1, "accuracy_mean"] > 0.7            # the SVM does learn Vulpi's terrains
    assert (table["infer_ms_per_window"] > 0).all() and (table["fit_s_per_fold"] > 0).all()
    cells = pd.read_csv(out / "compare_cells.csv")
    assert (cells.loc[cells["model"] == "cnn", "epochs_per_fold"] == 1).all()  # --quick: 1 epoch
    assert (cells["protocol"] == "grouped").all()
    # the protocol's settings travel with every cell, so merge_compare can refuse to pool
    # folders run under other folds or epochs; those of a CNN only on CNN rows
    assert (cells["n_splits"] == 2).all() and (cells["single_run_blocks"] == 5).all()
    assert (cells.loc[cells["model"] == "cnn", "max_epochs"] == 1).all()
    assert cells.loc[cells["model"] == "svm", "max_epochs"].isna().all()
    assert (cells.loc[cells["model"] == "cnn", "cnn_seeds"] == 1).all()
    activate_store()
    parent = mlflow.search_runs(experiment_names=["terrain-compare"],
                                filter_string="attributes.run_name = 'compare'")
    children = mlflow.search_runs(
        experiment_names=["terrain-compare"],
        filter_string=f"tags.mlflow.parentRunId = '{parent.run_id.iloc[0]}'")
    assert len(children) == 2 and "metrics.accuracy_k10" in children.columns
    # Vulpi's single-run class is cut into time blocks: said once, as terrain cv says it
    out_text = capsys.readouterr().out
    assert out_text.count("note: vulpi: class DIRT_ROAD has a single run: cut into 5") == 1
    assert (cells["n_windows_dropped"] == 0).all()
    assert (children["metrics.n_windows_dropped"] == 0).all()


@pytest.mark.slow
def test_a_failing_cell_closes_the_local_dask_cluster(monkeypatch):
    # the local cluster (two worker processes) was closed only when the grid ended well:
    # an exception inside the block left it running
    import distributed

    made = []

    class Recorded(distributed.LocalCluster):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(distributed, "LocalCluster", Recorded)
    with pytest.raises(RuntimeError, match="cell failed"):
        with joblib_backend("dask"):
            raise RuntimeError("cell failed")
    assert len(made) == 1 and made[0].status.name == "closed"


def test_dask_local_cluster_gives_the_same_cells_as_local_runs():
    from distributed import LocalCluster

    config = CompareConfig(models=("svm",), signals=("imu",), windows_s=(2.0,),
                           datasets=("vulpi",), seeds=(0, 1), n_splits=2, history=(1,))
    local = run_grid(config)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None) as cluster:
        with joblib_backend("dask", cluster.scheduler_address) as n_jobs:
            remote = run_grid(config, n_jobs=n_jobs)
    assert [r["cell"] for r in remote] == [r["cell"] for r in local]
    for a, b in zip(local, remote):
        assert a["rows"][0]["accuracy"] == pytest.approx(b["rows"][0]["accuracy"])
        pd.testing.assert_frame_equal(a["predictions"], b["predictions"])


def test_an_address_with_the_local_backend_is_refused_before_any_run(tmp_path, capsys,
                                                                     monkeypatch):
    # loky runs the grid here: an address (a cluster the user meant to use) was ignored
    from terrain.cli import main
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match="needs --backend dask or ray"):
        with joblib_backend("loky", "tcp://scheduler:8786"):
            pass
    with pytest.raises(ConfigError, match="unknown backend"):
        with joblib_backend("spark"):
            pass
    monkeypatch.chdir(tmp_path)
    assert main(["compare", "--address", "tcp://scheduler:8786", "--out", "c"]) == 2
    assert "--address tcp://scheduler:8786 needs --backend dask or ray" in \
        capsys.readouterr().err
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_soft_vote_of_cv_predictions_equals_the_fixed_weight_ensemble():
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import FunctionTransformer

    from terrain.models.compare import soft_vote
    from terrain.models.cv import cross_validate
    from terrain.models.ensemble import SoftVotingEnsemble

    rng = np.random.default_rng(0)
    groups = np.repeat([f"r{i}" for i in range(10)], 8)
    y = np.where(np.arange(80) // 8 % 2 == 0, "A", "B")
    X = rng.normal(0, 1, (80, 2, 10)) + (y == "B")[:, None, None] * 0.7
    flat = FunctionTransformer(lambda a: a.reshape(len(a), -1))
    means = FunctionTransformer(lambda a: a.mean(axis=2))
    members = [("flat", make_pipeline(flat, LogisticRegression(C=0.1))),
               ("mean", make_pipeline(means, LogisticRegression()))]
    t = np.tile(np.arange(8) * 2.0, 10)
    args = (X, y, groups, groups, t, t + 2.0, "grouped", (0,), 5)
    single = [cross_validate(lambda s, m=m: m, *args).predictions for _, m in members]
    ens = cross_validate(lambda s: SoftVotingEnsemble(members, weights=(1, 3)), *args)
    voted = soft_vote(single, ["A", "B"], weights=(1, 3))
    ref = ens.predictions.sort_values(["seed", "fold", "run", "t_start_s"])
    np.testing.assert_allclose(voted["proba_B"], ref["proba_B"], atol=1e-12)
    assert (voted["predicted"].to_numpy() == ref["predicted"].to_numpy()).all()
    with pytest.raises(ConfigError, match="same folds"):
        soft_vote([single[0], single[1].iloc[1:]], ["A", "B"])
    with pytest.raises(ConfigError, match="at least one member"):     # an IndexError before
        soft_vote([], ["A", "B"])


def test_early_stopping_reaches_the_cnns():
    from terrain.models.registry import ModelConfig, make_model

    config = CompareConfig(models=("cnn-spectrogram",), early_stopping=True)
    assert config.early_stopping and not CompareConfig().early_stopping
    for kind in ("cnn", "cnn-spectrogram"):
        model = make_model(ModelConfig(kind=kind, early_stopping=True), ("ax", "ay"), 50.0,
                           "vulpi")
        assert model.early_stopping is True
    assert make_model(ModelConfig(kind="cnn"), ("ax",), 50.0, "vulpi").early_stopping is False


@pytest.mark.slow
def test_paper_protocol_is_explicit_and_labelled_leaky():
    from terrain.models.compare import markdown_table, run_cell, summary_table

    with pytest.raises(ConfigError, match="unknown protocol"):
        CompareConfig(protocol="random")
    with pytest.raises(ConfigError, match="1.7 s windows"):
        CompareConfig(protocol="paper", windows_s=(2.0,))
    assert CompareConfig().protocol == "grouped"                     # never the default
    config = CompareConfig(models=("svm",), signals=("all",), windows_s=(1.7,),
                           datasets=("vulpi",), seeds=(0,), history=(1,), n_splits=2,
                           protocol="paper")
    (cell,) = config.cells()
    res = run_cell(cell, config)
    pred = res["predictions"]
    assert (pred["protocol"] == "paper").all()
    # split units are 5 s partitions, and runs do land on both sides: the protocol leaks
    assert pred["group"].str.contains("#").all()
    folds_per_run = pred.groupby("run")["fold"].nunique()
    assert (folds_per_run > 1).any()
    assert (pred["t_end_s"] - pred["t_start_s"]).round(3).eq(1.7).all()
    table = summary_table(pd.DataFrame(res["rows"]))
    assert "paper (LEAKY)" in markdown_table(table)
    assert res["rows"][0]["accuracy"] > 0.8


def _compare_folder(path, model, proba_b, with_protocol):
    """A ``terrain compare`` output folder of one model (cells + predictions), 1 seed."""
    runs = np.repeat(["A/1", "A/2", "B/1", "B/2"], 3)
    true = np.array([r[0] for r in runs])
    preds = pd.DataFrame({"seed": 0, "fold": np.repeat([0, 1, 0, 1], 3), "run": runs,
                          "group": runs, "t_start_s": np.tile([0.0, 2.0, 4.0], 4),
                          "t_end_s": np.tile([2.0, 4.0, 6.0], 4), "true": true,
                          "predicted": np.where(proba_b > 0.5, "B", "A"),
                          "proba_A": 1 - proba_b, "proba_B": proba_b, "model": model,
                          "signals": "all", "window_s": 2.0, "dataset": "toy"})
    acc = float((preds["predicted"] == preds["true"]).mean())
    cells = pd.DataFrame([{"model": model, "signals": "all", "window_s": 2.0,
                           "dataset": "toy", "seed": 0, "fit_s_per_fold": 1.0,
                           "infer_ms_per_window": 0.5, "cell_wall_s": 2.0, "history": 1,
                           "accuracy": acc, "balanced_accuracy": acc, "macro_f1": acc,
                           "run_vote_accuracy": acc, "n_windows": 12}])
    if with_protocol:
        preds["protocol"] = cells["protocol"] = "grouped"
    path.mkdir()
    preds.to_csv(path / "predictions.csv", index=False)
    cells.to_csv(path / "compare_cells.csv", index=False)


def test_merge_compare_votes_across_folders_with_and_without_protocol(tmp_path, monkeypatch):
    import runpy
    import sys

    # m1 is confidently wrong on run A/2, m2 mildly right there: the vote is right everywhere
    m1 = np.array([0.1] * 3 + [0.9] * 3 + [0.8] * 6)
    m2 = np.array([0.3] * 3 + [0.05] * 3 + [0.4] * 3 + [0.9] * 3)
    _compare_folder(tmp_path / "old", "m1", m1, with_protocol=False)  # before the column
    _compare_folder(tmp_path / "new", "m2", m2, with_protocol=True)
    out = tmp_path / "merged"
    monkeypatch.setattr(sys, "argv", [
        "merge_compare.py", str(tmp_path / "old"), str(tmp_path / "new"), "--vote", "m1",
        "m2", "--vote", "m2", "m1", "--history", "1", "--out", str(out)])
    with pytest.raises(SystemExit) as done:
        runpy.run_path(str(Path(__file__).parents[2] / "benchmarks" / "merge_compare.py"),
                       run_name="__main__")
    assert done.value.code == 0
    cells = pd.read_csv(out / "compare_cells.csv").set_index("model")
    assert cells.loc["m1", "accuracy"] == pytest.approx(0.75)
    assert cells.loc["m2", "accuracy"] == pytest.approx(0.75)
    for vote in ("vote(m1+m2)", "vote(m2+m1)"):
        assert cells.loc[vote, "accuracy"] == pytest.approx(1.0)
        assert cells.loc[vote, "fit_s_per_fold"] == pytest.approx(2.0)
        assert cells.loc[vote, "protocol"] == "grouped"
    assert "vote(m1+m2)" in (out / "compare_table.md").read_text()


def test_merge_compare_refuses_a_cell_given_by_two_folders(tmp_path, monkeypatch, capsys):
    import runpy
    import sys

    # the same model and seed in two folders (a rerun beside the first run) would count as
    # two seeds in the table's mean and spread and double the vote's windows
    m1 = np.array([0.1] * 3 + [0.9] * 3 + [0.8] * 6)
    _compare_folder(tmp_path / "first", "m1", m1, with_protocol=True)
    _compare_folder(tmp_path / "rerun", "m1", m1, with_protocol=True)
    out = tmp_path / "merged"
    monkeypatch.setattr(sys, "argv", [
        "merge_compare.py", str(tmp_path / "first"), str(tmp_path / "rerun"), "--vote", "m1",
        "--history", "1", "--out", str(out)])
    with pytest.raises(SystemExit) as done:
        runpy.run_path(str(Path(__file__).parents[2] / "benchmarks" / "merge_compare.py"),
                       run_name="__main__")
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert "m1" in err and "first" in err and "rerun" in err and "seed 0" in err
    assert not out.exists()


@pytest.mark.slow
@pytest.mark.parametrize("setting,first,second,models", [
    ("n_splits", 5, 3, ("m1", "m2")),          # folds differ: the vote's members too
    ("max_epochs", 30, 1, ("m1", "m1")),       # one model's seeds trained for other epochs
    ("cnn_seeds", 1, 3, ("m1", "m1"))])
def test_merge_compare_refuses_folders_run_with_other_settings(
        tmp_path, monkeypatch, capsys, setting, first, second, models):
    import runpy
    import sys

    m = np.array([0.1] * 3 + [0.9] * 3 + [0.8] * 6)
    for name, model, value, seed in (("a", models[0], first, 0), ("b", models[1], second, 1)):
        _compare_folder(tmp_path / name, model, m, with_protocol=True)
        for csv in ("compare_cells.csv", "predictions.csv"):
            frame = pd.read_csv(tmp_path / name / csv).assign(seed=seed)
            if csv == "compare_cells.csv":
                frame[setting] = value
            frame.to_csv(tmp_path / name / csv, index=False)
    out = tmp_path / "merged"
    argv = ["merge_compare.py", str(tmp_path / "a"), str(tmp_path / "b"), "--vote",
            *dict.fromkeys(models), "--history", "1", "--out", str(out)]
    monkeypatch.setattr(sys, "argv", argv)
    with pytest.raises(SystemExit) as done:
        runpy.run_path(str(Path(__file__).parents[2] / "benchmarks" / "merge_compare.py"),
                       run_name="__main__")
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert setting in err and f"{first}" in err and f"{second}" in err
    assert str(tmp_path / "a") in err and str(tmp_path / "b") in err
    assert not out.exists()
    # the same folders under one setting merge (and a folder recording none is not checked)
    cells = pd.read_csv(tmp_path / "b" / "compare_cells.csv")
    cells.assign(**{setting: first}).to_csv(tmp_path / "b" / "compare_cells.csv", index=False)
    with pytest.raises(SystemExit) as done:
        runpy.run_path(str(Path(__file__).parents[2] / "benchmarks" / "merge_compare.py"),
                       run_name="__main__")
    assert done.value.code == 0
    cells.drop(columns=setting).to_csv(tmp_path / "b" / "compare_cells.csv", index=False)
    monkeypatch.setattr(sys, "argv", argv[:-1] + [str(tmp_path / "merged2")])
    with pytest.raises(SystemExit) as done:
        runpy.run_path(str(Path(__file__).parents[2] / "benchmarks" / "merge_compare.py"),
                       run_name="__main__")
    assert done.value.code == 0


@pytest.mark.slow
def test_a_failing_cell_leaves_the_finished_cells_logged_and_saved(workdir, capsys):
    import mlflow

    from terrain.tracking import activate_store

    out = workdir / "cmp"
    # the first cell (2 s windows) runs; the second asks for windows longer than every
    # Vulpi run (valid settings, so only the cell itself can find out that no window is
    # left) and fails
    status = main(["compare", "--models", "svm", "--signals", "imu", "--windows-s", "2",
                   "5000", "--datasets", "vulpi", "--seeds", "0", "--history", "1",
                   "--n-jobs", "1", "--out", str(out)])
    err = capsys.readouterr().err
    assert status != 0 and "no window left" in err and "Traceback" not in err
    cells = pd.read_csv(out / "compare_cells.csv")
    assert list(cells["signals"]) == ["imu"] and cells["accuracy"].iloc[0] > 0.5
    activate_store()
    children = mlflow.search_runs(experiment_names=["terrain-compare"],
                                  filter_string="attributes.run_name = "
                                                "'svm-vulpi-imu-2s-seed0'")
    assert len(children) == 1


def test_grid_figure_has_one_heatmap_per_model_and_dataset_with_blank_cells_not_run():
    import matplotlib

    matplotlib.use("Agg")
    from terrain.models.compare import plot_grid, spans_grid

    rows = [dict(dataset=d, model=m, signals=s, window_s=w, history=k,
                 accuracy_mean=0.9 if s == "all" else 0.6, macro_f1_mean=0.85)
            for d in ("borealtc", "vulpi") for m in ("svm", "cnn") for s in ("imu", "all")
            for w in (1.0, 2.0) for k in (1, 10) if not (d == "vulpi" and s == "imu" and w == 1.0)]
    table = pd.DataFrame(rows)
    assert spans_grid(table) and not spans_grid(table[(table.signals == "all")
                                                      & (table.window_s == 2.0)])
    fig = plot_grid(table)
    heatmaps = [ax for ax in fig.axes if ax.get_title()]
    assert sorted(ax.get_title() for ax in heatmaps) == [
        "cnn / borealtc", "cnn / vulpi", "svm / borealtc", "svm / vulpi"]
    vulpi = next(ax for ax in heatmaps if ax.get_title() == "svm / vulpi")
    image = vulpi.get_images()[0].get_array()
    assert image.shape == (2, 2)
    assert np.ma.is_masked(image[0, 0]) or np.isnan(image[0, 0])   # imu, 1 s: not run
    assert image[1, 0] == pytest.approx(0.9)        # row "all", 1 s
    assert len(vulpi.texts) == 3                    # the cell not run has no text
    with pytest.raises(ConfigError, match="history"):
        plot_grid(table, history=5)
    mixed = pd.concat([table.assign(train_hop_s=np.nan), table.assign(train_hop_s=0.5)])
    assert not spans_grid(mixed)                    # two training cuts: no grid view
    with pytest.raises(ConfigError, match="one protocol and one training-window hop"):
        plot_grid(mixed)


def test_grid_markdown_bolds_the_best_of_each_column_and_marks_cells_not_run():
    from terrain.models.compare import grid_markdown

    table = pd.DataFrame([
        dict(dataset="vulpi", model=m, signals=s, window_s=w, history=1,
             accuracy_mean=acc, macro_f1_mean=acc - 0.01)
        for m, s, w, acc in [("svm", "all", 2.0, 0.925), ("cnn", "all", 2.0, 0.85),
                             ("svm", "imu", 2.0, 0.91), ("svm", "all", 4.0, 0.951)]])
    md = grid_markdown(table, history=(1, 10))
    lines = md.splitlines()
    assert lines[0] == "#### vulpi" and "| signals | model | 2 s, k = 1 | 4 s, k = 1 |" in md
    assert "| all | svm | **0.925 / 0.915** | **0.951 / 0.941** |" in lines
    assert "| all | cnn | 0.850 / 0.840 | - |" in lines
    assert "| imu | svm | 0.910 / 0.900 | - |" in lines
    assert not any(line.startswith("| imu | cnn |") for line in lines)   # never run


@pytest.mark.parametrize("argv, message", [
    (["cv", "--dataset", "borealtc", "--model", "minirocket"], "the minirocket model needs aeon"),
    (["train", "--dataset", "borealtc", "--model", "minirocket", "--model-out", "m"],
     "the minirocket model needs aeon"),
    (["compare", "--models", "svm", "minirocket", "--out", "c"], "the minirocket model needs aeon"),
    (["compare", "--backend", "ray", "--out", "c"], "the ray backend needs the optional extra"),
])
def test_a_missing_optional_extra_is_refused_before_any_run(argv, message, tmp_path,
                                                            capsys, monkeypatch):
    # aeon and ray are optional extras: without them the command stops with the install hint
    # before it reads data or opens an MLflow run (it used to open one, then fail)
    import importlib.util

    from terrain.cli import main

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name in ("aeon", "ray") else real(name, *a))
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())     # no mlflow.db, no mlruns, no output folder


def _seed_rows(values: dict[str, list[float]], **fields) -> pd.DataFrame:
    """Rows of one (model, signals, window, dataset, history) group, one per seed."""
    n = len(next(iter(values.values())))
    base = {"protocol": "grouped", "dataset": "toy", "signals": "all", "window_s": 2.0,
            "train_hop_s": 2.0, "history": 1, "model": "svm", "fit_s_per_fold": 1.0,
            "infer_ms_per_window": 0.5, **fields}
    return pd.DataFrame([{**base, "seed": s, **{k: v[s] for k, v in values.items()}}
                         for s in range(n)])


def test_summary_table_does_not_average_over_a_seed_missing_a_metric():
    from terrain.models.compare import summary_table

    nan = float("nan")
    rows = _seed_rows({"accuracy": [0.9, 0.5, 0.7], "balanced_accuracy": [0.8] * 3,
                       "macro_f1": [0.8] * 3, "run_vote_accuracy": [1.0, 1.0, nan]})
    (row,) = summary_table(rows).to_dict(orient="records")
    assert row["n_seeds"] == 3
    assert row["accuracy_mean"] == pytest.approx(0.7)
    # spread over seeds: the population std (ddof=0), as CVReport.summary gives it
    assert row["accuracy_std"] == pytest.approx(np.sqrt(0.08 / 3))
    # seed 2 has no run vote: a mean of the two others would claim 1.0 over 3 seeds
    assert np.isnan(row["run_vote_accuracy_mean"]) and np.isnan(row["run_vote_accuracy_std"])


def test_comparison_figure_puts_each_bar_over_its_own_model():
    from matplotlib.container import BarContainer

    from terrain.models.compare import plot_comparison

    # the cnn cell was run at k = 1 only: svm's k = 10 bar must stay at svm's place
    table = pd.concat([_seed_rows({"accuracy_mean": [0.71], "accuracy_std": [0.0]},
                                  model="cnn"),
                       _seed_rows({"accuracy_mean": [0.91], "accuracy_std": [0.0]}),
                       _seed_rows({"accuracy_mean": [1.0], "accuracy_std": [0.0]},
                                  history=10)])
    ax = plot_comparison(table).axes[0]
    names = [t.get_text().split("\n")[0] for t in ax.get_xticklabels()]
    ticks = dict(zip(names, ax.get_xticks()))
    bars = {c.get_label(): [(p.get_x() + p.get_width() / 2, p.get_height())
                            for p in c.patches]
            for c in ax.containers if isinstance(c, BarContainer)}
    (x10, height10), = bars["k=10"]
    assert height10 == 1.0
    assert abs(x10 - ticks["svm"]) < abs(x10 - ticks["cnn"])


def test_history_refuses_rows_of_several_seeds():
    from terrain.models.compare import score_rows

    one = pd.DataFrame({"group": ["r1"] * 3, "t_start_s": [0.0, 2.0, 4.0], "true": ["A"] * 3,
                        "proba_A": [0.9] * 3, "proba_B": [0.1] * 3})
    seed1 = one.assign(seed=1, proba_A=[0.2, 0.2, 0.45], proba_B=[0.8, 0.8, 0.55])
    np.testing.assert_array_equal(history_predictions(seed1, ["A", "B"], 2), ["B"] * 3)
    # seed 1's history must not take seed 0's window at the same time (it gave A, A, A)
    both = pd.concat([one.assign(seed=0), seed1], ignore_index=True)
    with pytest.raises(ConfigError, match="more than once"):
        history_predictions(both, ["A", "B"], 2)
    with pytest.raises(ConfigError, match="one seed"):
        score_rows(both, ["A", "B"], (1, 2), {})


@pytest.mark.parametrize("history", [(1, 2.5), (True,), (1, 0), (1, 5, 1)])
def test_history_lengths_must_be_integers_before_any_cell(history):
    # history=(1, 2.5) passed the ">= 1" check; every cell then cross-validated its model
    # and failed scoring it with pandas' bare "window must be an integer 0 or greater"
    with pytest.raises(ConfigError, match="history"):
        CompareConfig(models=("svm",), signals=("all",), windows_s=(2.0,),
                      datasets=("vulpi",), seeds=(0,), history=history)


def test_the_grid_holds_every_combination_of_its_axes_once():
    # each (model, signals, window, dataset, seed) is one cell: a seed or any axis value
    # left out would be a cell silently never run
    import itertools

    config = CompareConfig(models=("svm", "cnn"), signals=("imu", "all"), windows_s=(1.0, 2.0),
                           datasets=("vulpi",), seeds=(0, 1, 2), history=(1,))
    cells = config.cells()
    got = [(c.model, c.signals, c.window_s, c.dataset, c.seed) for c in cells]
    assert len(got) == 2 * 2 * 2 * 1 * 3
    assert set(got) == set(itertools.product(("svm", "cnn"), ("imu", "all"), (1.0, 2.0),
                                             ("vulpi",), (0, 1, 2)))
    assert {(c.protocol, c.train_hop_s) for c in cells} == {("grouped", None)}


def _two_run_windows():
    """Four windows of two 4 s runs (r1: A, r2: B) in the shape cell_windows returns."""
    from types import SimpleNamespace

    ws = SimpleNamespace(X=np.zeros((4, 1, 5)), run_ids=np.array(["r1", "r1", "r2", "r2"]),
                         t_start_s=np.array([0.0, 2.0, 0.0, 2.0]),
                         t_end_s=np.array([2.0, 4.0, 2.0, 4.0]), channels=("ax",),
                         rate_hz=50.0)
    return ws, np.array(["A", "A", "B", "B"])


def _perfect_cv(seed, y, groups, run_ids, t0, t1):
    """A cross_validate result on :func:`_two_run_windows` that names every window right
    (two folds; fit 1 and 3 s, inference 0.5 and 1.5 ms per window)."""
    from types import SimpleNamespace

    pred = pd.DataFrame({"seed": seed, "fold": [0, 0, 1, 1], "run": run_ids, "group": groups,
                         "t_start_s": t0, "t_end_s": t1, "true": y, "predicted": y,
                         "proba_A": [0.9, 0.8, 0.2, 0.1], "proba_B": [0.1, 0.2, 0.8, 0.9]})
    folds = pd.DataFrame({"fit_s": [1.0, 3.0], "infer_ms_per_window": [0.5, 1.5]})
    return SimpleNamespace(predictions=pred, classes=["A", "B"], folds=folds)


def test_a_cell_cross_validates_with_its_own_seed_and_reports_means_over_folds(monkeypatch):
    # the cell's seed must reach the CV (its split and models): every seed of a grid gave
    # the same cell otherwise; the times per fold are means over the folds
    import terrain.models.compare as compare

    ws, labels = _two_run_windows()
    monkeypatch.setattr(compare, "cell_windows", lambda cell, n: compare.CellWindows(
        ws, labels, ws.run_ids, None, (), 0, ()))
    seen = {}

    def fake_cv(factory, X, y, groups, run_ids, t0, t1, protocol, seeds, n_splits, **kw):
        seen.update(seeds=seeds, n_splits=n_splits)
        return _perfect_cv(seeds[0], y, groups, run_ids, t0, t1)

    monkeypatch.setattr(compare, "cross_validate", fake_cv)
    config = CompareConfig(models=("svm",), signals=("all",), windows_s=(2.0,),
                           datasets=("vulpi",), seeds=(7,), history=(1,), n_splits=3)
    res = compare.run_cell(config.cells()[0], config)
    assert seen == {"seeds": (7,), "n_splits": 3}
    (row,) = res["rows"]
    assert (row["seed"], row["fit_s_per_fold"], row["infer_ms_per_window"]) == (7, 2.0, 1.0)
    assert row["accuracy"] == 1.0 and (res["predictions"]["seed"] == 7).all()


def test_summary_table_keeps_cells_of_other_training_hops_apart():
    from terrain.models.compare import summary_table

    # the same cell trained on non-overlapping windows and on 0.5 s hops: two rows, never
    # one mean over both as if they were two seeds
    rows = pd.concat([_seed_rows({"accuracy": [0.8], "balanced_accuracy": [0.8],
                                  "macro_f1": [0.8], "run_vote_accuracy": [0.8]},
                                 train_hop_s=np.nan),
                      _seed_rows({"accuracy": [0.9], "balanced_accuracy": [0.9],
                                  "macro_f1": [0.9], "run_vote_accuracy": [0.9]},
                                 train_hop_s=0.5)])
    table = summary_table(rows).set_index("train_hop_s")
    assert sorted(table.index) == [0.5, 2.0] and (table["n_seeds"] == 1).all()
    assert table.loc[0.5, "accuracy_mean"] == 0.9 and table.loc[2.0, "accuracy_mean"] == 0.8


def test_a_dask_address_is_used_and_no_local_cluster_is_started(monkeypatch):
    import distributed
    from distributed import LocalCluster, get_client

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster:
        made = []
        monkeypatch.setattr(distributed, "LocalCluster",
                            lambda *a, **k: made.append(1) or cluster)
        with joblib_backend("dask", cluster.scheduler_address) as n_jobs:
            assert get_client().scheduler.address == cluster.scheduler_address
        assert n_jobs == -1 and made == []


@pytest.mark.parametrize("settings, message", [
    (dict(n_splits=1), r"n_splits must be an integer >= 2, got 1"),
    (dict(n_splits=2.5), r"n_splits must be an integer >= 2, got 2.5"),
    (dict(max_epochs=0), r"max_epochs must be an integer >= 1, got 0"),
    (dict(max_epochs=1.5), r"max_epochs must be an integer >= 1, got 1.5"),
    (dict(n_threads=0), "thread")])
def test_fold_epoch_and_thread_settings_are_checked_before_any_cell(settings, message):
    # a single fold has no held-out runs: each cell would fail after loading its data
    with pytest.raises(ConfigError, match=message):
        CompareConfig(models=("svm",), signals=("all",), windows_s=(2.0,),
                      datasets=("vulpi",), seeds=(0,), history=(1,), **settings)


@pytest.mark.parametrize("axis", ["models", "signals", "windows_s", "datasets", "history"])
def test_an_empty_axis_is_refused_by_name(axis):
    # models=() gave zero cells, and terrain compare then failed in summary_table with a
    # bare KeyError (library callers: the CLI's nargs="+" never passes an empty axis)
    one = dict(models=("svm",), signals=("all",), windows_s=(2.0,), datasets=("vulpi",),
               seeds=(0,), history=(1,))
    assert len(CompareConfig(**one).cells()) == 1
    with pytest.raises(ConfigError, match=f"{axis} is empty"):
        CompareConfig(**{**one, axis: ()})


def test_rows_without_a_protocol_or_training_hop_are_grouped_non_overlapping_ones():
    from terrain.models.compare import with_default_keys

    # rows of an older run (no protocol, no hop) joined with newer ones: NaN keys
    rows = pd.DataFrame({"window_s": [2.0, 1.7], "protocol": [None, "paper"],
                         "train_hop_s": [np.nan, 0.5]})
    keyed = with_default_keys(rows)
    assert keyed["protocol"].tolist() == ["grouped", "paper"]
    assert keyed["train_hop_s"].tolist() == [2.0, 0.5]


def _fake_ray(monkeypatch, initialized: bool) -> list:
    """A stand-in ``ray`` package (not installed here) that records its calls; its joblib
    backend is loky's."""
    import importlib.machinery
    import sys
    import types

    from joblib import register_parallel_backend
    from joblib._parallel_backends import LokyBackend

    calls = []
    ray = types.ModuleType("ray")
    ray.is_initialized = lambda: initialized
    ray.init = lambda address=None, **kw: calls.append(("init", address))
    ray.shutdown = lambda: calls.append(("shutdown",))
    util, jl = types.ModuleType("ray.util"), types.ModuleType("ray.util.joblib")
    jl.register_ray = lambda: register_parallel_backend("ray", LokyBackend)
    ray.util, util.joblib = util, jl
    for name, module in (("ray", ray), ("ray.util", util), ("ray.util.joblib", jl)):
        module.__spec__ = importlib.machinery.ModuleSpec(name, None)   # find_spec's answer
        monkeypatch.setitem(sys.modules, name, module)
    return calls


def test_ray_backend_starts_and_stops_only_a_session_of_its_own(monkeypatch):
    # the sweep shut down a Ray session its caller had started (ray.shutdown() in any case)
    calls = _fake_ray(monkeypatch, initialized=False)
    with joblib_backend("ray", "ray://head:10001") as n_jobs:
        assert n_jobs == -1
    assert calls == [("init", "ray://head:10001"), ("shutdown",)]
    calls = _fake_ray(monkeypatch, initialized=True)
    with joblib_backend("ray", None):
        pass
    assert calls == []


def test_a_cell_keeps_its_training_hop_and_reports_what_its_cut_dropped(monkeypatch):
    # the grid's train_hop_s must reach every cell (its training cut, its table key), and
    # the windows its cut dropped and its notes must reach the rows and the result
    import terrain.models.compare as compare

    ws, labels = _two_run_windows()
    training = object()
    asked = {}

    def fake_windows(cell, n_blocks):
        asked.update(train_hop_s=cell.train_hop_s, n_blocks=n_blocks)
        return compare.CellWindows(ws, labels, ws.run_ids, training, ("A",), 3, ("a note",))

    def fake_cv(factory, X, y, groups, run_ids, t0, t1, protocol, seeds, n_splits, **kw):
        assert kw["training"] is training
        return _perfect_cv(seeds[0], y, groups, run_ids, t0, t1)

    monkeypatch.setattr(compare, "cell_windows", fake_windows)
    monkeypatch.setattr(compare, "cross_validate", fake_cv)
    config = CompareConfig(models=("svm",), signals=("all",), windows_s=(2.0,),
                           datasets=("vulpi",), seeds=(0,), history=(1,), train_hop_s=0.5,
                           single_run_blocks=4)
    (cell,) = config.cells()
    assert cell.train_hop_s == 0.5
    res = compare.run_cell(cell, config)
    assert asked == {"train_hop_s": 0.5, "n_blocks": 4}
    (row,) = res["rows"]
    assert row["train_hop_s"] == 0.5 and row["n_windows_dropped"] == 3
    assert res["notes"] == ["a note"] and (res["predictions"]["train_hop_s"] == 0.5).all()


@pytest.mark.parametrize("settings, message", [
    (dict(train_hop_s="0.5"), "train_hop_s must be a real number, got str '0.5'"),
    (dict(history=("5",)), "CompareConfig.history must be an integer >= 1, got '5'"),
    (dict(history=(1, "5")), "CompareConfig.history must be an integer >= 1, got '5'"),
])
def test_text_for_a_number_is_a_config_error_naming_the_setting(settings, message):
    # both reached Python's bare TypeError ("'>' not supported between instances of 'str'
    # and 'int'") in CompareConfig's own comparisons
    with pytest.raises(ConfigError, match=message):
        CompareConfig(models=("svm",), signals=("all",), windows_s=(2.0,),
                      datasets=("vulpi",), seeds=(0,), **settings)


def test_a_cell_without_a_window_says_so_as_terrain_cv_does(vulpi_runs, monkeypatch):
    # 200 s windows leave no Vulpi window: the cell reached the CV and failed there with
    # '5 folds over 0 split units', which names neither the windows nor the cause
    import terrain.io.shipped as shipped
    from terrain.models.compare import Cell, run_cell

    monkeypatch.setattr(shipped, "load_dataset", lambda name, data_dir=None: vulpi_runs)
    config = CompareConfig(models=("svm",), signals=("all",), windows_s=(200.0,),
                           datasets=("vulpi",), seeds=(0,), history=(1,))
    with pytest.raises(ConfigError, match="no window left for this dataset, signal set and "
                                          "window .dataset 'vulpi', signals all, 200 s"):
        run_cell(Cell("svm", "all", 200.0, "vulpi", 0), config)


def test_merge_compare_vote_times_do_not_depend_on_the_history_asked(tmp_path, monkeypatch):
    import runpy
    import sys

    # the folders' cells hold histories 1 and 10; a vote scored at history 3 took its
    # members' times from their history-3 rows, which do not exist: fit 0 s, inference 0 ms
    m1 = np.array([0.1] * 3 + [0.9] * 3 + [0.8] * 6)
    m2 = np.array([0.3] * 3 + [0.05] * 3 + [0.4] * 3 + [0.9] * 3)
    _compare_folder(tmp_path / "a", "m1", m1, with_protocol=True)
    _compare_folder(tmp_path / "b", "m2", m2, with_protocol=True)
    # and history 10 as well: each member's times are counted once, not once per history
    for folder in ("a", "b"):
        cells = pd.read_csv(tmp_path / folder / "compare_cells.csv")
        pd.concat([cells, cells.assign(history=10)]).to_csv(
            tmp_path / folder / "compare_cells.csv", index=False)
    out = tmp_path / "merged"
    monkeypatch.setattr(sys, "argv", [
        "merge_compare.py", str(tmp_path / "a"), str(tmp_path / "b"), "--vote", "m1", "m2",
        "--history", "3", "--out", str(out)])
    with pytest.raises(SystemExit) as done:
        runpy.run_path(str(Path(__file__).parents[2] / "benchmarks" / "merge_compare.py"),
                       run_name="__main__")
    assert done.value.code == 0
    merged = pd.read_csv(out / "compare_cells.csv")
    vote = merged[merged["model"] == "vote(m1+m2)"].squeeze()
    assert vote["history"] == 3
    assert vote["fit_s_per_fold"] == pytest.approx(2.0)
    assert vote["infer_ms_per_window"] == pytest.approx(1.0)
