"""Property tests of the comparison tables, decision history and grid (cmp15 review)."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.models.compare import (TABLE_METRICS, CompareConfig, grid_markdown,
                                    history_predictions, markdown_table, summary_table)

KEYS = ["protocol", "dataset", "signals", "window_s", "train_hop_s", "history", "model"]
metric = st.one_of(st.floats(0.0, 1.0), st.just(float("nan")))


@st.composite
def cell_rows(draw):
    """Rows of a few groups (model x signals x window x history), 1-4 seeds each."""
    rows = []
    for model, signals, window_s, history in itertools.product(
            draw(st.sets(st.sampled_from(["svm", "cnn", "forest"]), min_size=1, max_size=2)),
            draw(st.sets(st.sampled_from(["imu", "all"]), min_size=1, max_size=2)),
            draw(st.sets(st.sampled_from([1.0, 2.0]), min_size=1, max_size=2)),
            draw(st.sets(st.sampled_from([1, 5]), min_size=1, max_size=2))):
        for seed in range(draw(st.integers(1, 4))):
            rows.append({**{m: draw(metric) for m in TABLE_METRICS},
                         "protocol": "grouped", "dataset": "vulpi", "signals": signals,
                         "window_s": window_s, "train_hop_s": window_s, "history": history,
                         "model": model, "seed": seed,
                         "fit_s_per_fold": draw(st.one_of(st.floats(0.0, 100.0),
                                                          st.just(float("nan")))),
                         "infer_ms_per_window": draw(st.floats(0.0, 10.0))})
    return pd.DataFrame(rows)


@pytest.mark.slow
@settings(max_examples=40, deadline=None)
@given(rows=cell_rows(), order=st.randoms(use_true_random=False))
def test_summary_equals_a_direct_computation_per_group_whatever_the_row_order(rows, order):
    table = summary_table(rows).set_index(KEYS)
    assert len(table) == rows.groupby(KEYS).ngroups
    for key, group in rows.groupby(KEYS):
        row = table.loc[key]
        assert row["n_seeds"] == len(group)
        for m in TABLE_METRICS:
            values = group[m].to_numpy(float)
            # a NaN in any seed makes the mean and the spread NaN
            np.testing.assert_allclose(row[m + "_mean"], np.mean(values), rtol=1e-12)
            np.testing.assert_allclose(row[m + "_std"], np.std(values), atol=1e-12)
        # the times as well: never the mean of fewer seeds than n_seeds says
        np.testing.assert_allclose(row["fit_s_per_fold"],
                                   np.mean(group["fit_s_per_fold"].to_numpy(float)))
    shuffled = rows.sample(frac=1.0, random_state=order.randrange(2 ** 31))
    pd.testing.assert_frame_equal(summary_table(shuffled), summary_table(rows), rtol=1e-12)


@pytest.mark.slow
@settings(max_examples=30, deadline=None)
@given(rows=cell_rows())
def test_markdown_shows_every_group_once(rows):
    table = summary_table(rows)
    lines = markdown_table(table).splitlines()[2:]
    assert len(lines) == len(table)
    shown = [tuple(c.strip() for c in line.strip("|").split("|")) for line in lines]
    assert len(set(c[:6] for c in shown)) == len(shown)
    for cells, (_, r) in zip(shown, table.iterrows()):      # in the table's row order
        assert cells[5] == r["model"] and cells[12] == str(r["n_seeds"])
        for j, m in enumerate(TABLE_METRICS):
            assert cells[6 + j] == f"{r[m + '_mean']:.3f} ± {r[m + '_std']:.3f}"


@pytest.mark.slow
@settings(max_examples=30, deadline=None)
@given(rows=cell_rows())
def test_grid_markdown_bolds_exactly_the_best_accuracy_of_each_column(rows):
    table = summary_table(rows.fillna(0.5))
    md = grid_markdown(table, history=(1, 5))
    lines = [line for line in md.splitlines() if line.startswith("| ") and "---" not in line]
    head, body = lines[0], lines[1:]
    assert len(body) == table.groupby(["signals", "model"]).ngroups
    columns = [c.strip() for c in head.strip("|").split("|")][2:]
    cells = [[c.strip() for c in line.strip("|").split("|")] for line in body]
    assert len(set((c[0], c[1]) for c in cells)) == len(cells)       # each row once
    for j, name in enumerate(columns):
        w, k = name.split(" s, k = ")
        sub = table[(table["window_s"] == float(w)) & (table["history"] == int(k))]
        best = f"{sub['accuracy_mean'].max():.3f}"
        for c in cells:
            text = c[2 + j]
            if text == "-":
                assert not ((sub["signals"] == c[0]) & (sub["model"] == c[1])).any()
                continue
            acc = sub[(sub["signals"] == c[0]) & (sub["model"] == c[1])]["accuracy_mean"]
            assert text.strip("*").split(" / ")[0] == f"{acc.item():.3f}"
            assert text.startswith("**") == (acc.item() == sub["accuracy_mean"].max())
        assert any(c[2 + j].startswith(f"**{best}") for c in cells)


@st.composite
def predictions(draw):
    """Out-of-fold rows of one seed: a few runs, a few windows each, 2-3 classes."""
    classes = ["A", "B", "C"][:draw(st.integers(2, 3))]
    rows = []
    for r in range(draw(st.integers(1, 3))):
        for i in range(draw(st.integers(1, 6))):
            p = np.array(draw(st.lists(st.sampled_from([0.0, 0.1, 0.25, 0.5, 1.0]),
                                       min_size=len(classes), max_size=len(classes))))
            p = p + 1e-3 if p.sum() == 0 else p
            rows.append({"group": f"r{r}", "t_start_s": 2.0 * i,
                         **{f"proba_{c}": v for c, v in zip(classes, p / p.sum())}})
    frame = pd.DataFrame(rows)
    perm = draw(st.permutations(range(len(frame))))
    return frame.iloc[list(perm)], classes


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(data=predictions(), k=st.integers(1, 7))
def test_history_decision_is_the_brute_force_mean_of_the_last_k_windows(data, k):
    frame, classes = data
    got = history_predictions(frame, classes, k)
    cols = [f"proba_{c}" for c in classes]
    for i, (_, row) in enumerate(frame.iterrows()):
        run = frame[(frame["group"] == row["group"])
                    & (frame["t_start_s"] <= row["t_start_s"])].sort_values("t_start_s")
        last = run[cols].to_numpy()[-k:]
        total = np.zeros(len(cols))
        for p in last:          # summed oldest first, as one would by hand
            total = total + p
        mean = total / len(last)
        # the largest mean of exactly those windows; a tie goes to the first class
        assert got[i] == classes[int(np.argmax(mean))], (i, mean)


def test_a_tie_of_the_last_k_windows_goes_to_the_first_class_whatever_came_before():
    # the last 2 windows of the run average to exactly 0.5 / 0.5 (a tie: A); a rolling mean
    # kept the rounding of the 4 s window that had left the history and decided B
    p = np.array([[0.5, 0.5], [0.5, 0.5], [0.1, 0.25], [1.0, 0.1], [0.1, 1.0]])
    p = p / p.sum(axis=1, keepdims=True)
    frame = pd.DataFrame({"group": "r0", "t_start_s": [0.0, 2.0, 4.0, 6.0, 8.0],
                          "proba_A": p[:, 0], "proba_B": p[:, 1]})
    assert p[3:].mean(axis=0)[0] == p[3:].mean(axis=0)[1]
    assert history_predictions(frame, ["A", "B"], 2)[-1] == "A"
    assert history_predictions(frame.iloc[3:], ["A", "B"], 2)[-1] == "A"


@settings(max_examples=15, deadline=None)
@given(models=st.lists(st.sampled_from(["svm", "cnn", "cnn-spectrogram"]), min_size=1, max_size=3,
                       unique=True),
       signals=st.lists(st.sampled_from(["imu", "wheels", "all"]), min_size=1, max_size=3,
                        unique=True),
       windows=st.lists(st.sampled_from([1.0, 2.0, 4.0]), min_size=1, max_size=2, unique=True),
       datasets=st.lists(st.sampled_from(["vulpi", "borealtc"]), min_size=1, max_size=2,
                         unique=True),
       seeds=st.lists(st.integers(0, 5), min_size=1, max_size=3, unique=True))
def test_cells_are_the_full_cross_product_each_once(models, signals, windows, datasets, seeds):
    config = CompareConfig(models=tuple(models), signals=tuple(signals),
                           windows_s=tuple(windows), datasets=tuple(datasets),
                           seeds=tuple(seeds))
    cells = config.cells()
    got = {(c.model, c.signals, c.window_s, c.dataset, c.seed) for c in cells}
    assert len(cells) == len(got)
    assert got == set(itertools.product(models, signals, windows, datasets, seeds))
    assert all(c.protocol == "grouped" and c.train_hop_s is None for c in cells)


@pytest.mark.slow
@settings(max_examples=20, deadline=None)
@given(rows=cell_rows())
def test_the_written_tables_read_back_equal(rows, tmp_path_factory):
    path = tmp_path_factory.mktemp("csv")
    table = summary_table(rows)
    rows.to_csv(path / "compare_cells.csv", index=False)
    table.to_csv(path / "compare_table.csv", index=False)
    back = pd.read_csv(path / "compare_table.csv")
    pd.testing.assert_frame_equal(back, table, check_dtype=False)
    pd.testing.assert_frame_equal(summary_table(pd.read_csv(path / "compare_cells.csv")),
                                  table, check_dtype=False)


if __name__ == "__main__":   # pragma: no cover
    pytest.main([__file__])


def _folder(path, cells):
    """A ``terrain compare`` output folder of the given (model, seed) cells on toy runs."""
    runs = np.repeat(["A/1", "A/2", "B/1", "B/2"], 3)
    preds, rows = [], []
    for model, seed, proba_b in cells:
        p = pd.DataFrame({"seed": seed, "fold": np.repeat([0, 1, 0, 1], 3), "run": runs,
                          "group": runs, "t_start_s": np.tile([0.0, 2.0, 4.0], 4),
                          "true": [r[0] for r in runs], "proba_A": 1 - proba_b,
                          "proba_B": proba_b, "model": model, "signals": "all",
                          "window_s": 2.0, "dataset": "toy", "protocol": "grouped"})
        preds.append(p)
        acc = float(((p["proba_B"] > 0.5) == (p["true"] == "B")).mean())
        rows.append({"model": model, "signals": "all", "window_s": 2.0, "dataset": "toy",
                     "protocol": "grouped", "seed": seed, "fit_s_per_fold": 1.0 + seed,
                     "infer_ms_per_window": 0.5, "history": 1, "accuracy": acc,
                     "balanced_accuracy": acc, "macro_f1": acc, "run_vote_accuracy": acc,
                     "n_windows": 12})
    path.mkdir()
    pd.concat(preds).to_csv(path / "predictions.csv", index=False)
    pd.DataFrame(rows).to_csv(path / "compare_cells.csv", index=False)


def _merge(dirs, out, *options):
    """Run benchmarks/merge_compare.py on ``dirs``; its exit status."""
    import runpy
    import sys
    from pathlib import Path
    from unittest import mock

    script = Path(__file__).parents[2] / "benchmarks" / "merge_compare.py"
    argv = ["merge_compare.py", *map(str, dirs), *options, "--out", str(out)]
    with mock.patch.object(sys, "argv", argv), pytest.raises(SystemExit) as done:
        runpy.run_path(str(script), run_name="__main__")
    return done.value.code


@pytest.mark.slow
@settings(max_examples=6, deadline=None)
@given(cells=st.lists(st.tuples(st.sampled_from(["m1", "m2", "m3"]), st.integers(0, 2),
                                st.lists(st.floats(0.0, 1.0), min_size=12, max_size=12)),
                      min_size=2, max_size=5, unique_by=lambda c: c[:2]),
       split=st.data())
def test_merging_two_folders_equals_one_folder_of_their_union(cells, split,
                                                              tmp_path_factory):
    import matplotlib.pyplot as plt

    cells = [(m, s, np.array(p)) for m, s, p in cells]
    side = split.draw(st.lists(st.booleans(), min_size=len(cells), max_size=len(cells)))
    if all(side) or not any(side):
        side[0] = not side[0]
    root = tmp_path_factory.mktemp("merge")
    _folder(root / "a", [c for c, s in zip(cells, side) if s])
    _folder(root / "b", [c for c, s in zip(cells, side) if not s])
    _folder(root / "union", cells)
    vote = ["--vote", "m1", "m2", "--history", "1", "3"]
    assert _merge([root / "a", root / "b"], root / "ab", *vote) == 0
    assert _merge([root / "b", root / "a"], root / "ba", *vote) == 0
    assert _merge([root / "union"], root / "one", *vote) == 0
    plt.close("all")
    one = pd.read_csv(root / "one" / "compare_table.csv")
    for merged in ("ab", "ba"):
        pd.testing.assert_frame_equal(pd.read_csv(root / merged / "compare_table.csv"), one,
                                      rtol=1e-12)
    per_seed = pd.read_csv(root / "ab" / "compare_cells.csv")
    assert len(per_seed[~per_seed["model"].str.startswith("vote")]) == len(cells)
    both = {s for m, s, _ in cells if m == "m1"} & {s for m, s, _ in cells if m == "m2"}
    votes = per_seed[per_seed["model"] == "vote(m1+m2)"]
    assert sorted(votes["seed"]) == sorted(2 * list(both))      # histories 1 and 3
    # the window-level vote of history 1: the mean of the members' probabilities
    for seed in both:
        p = np.mean([c[2] for c in cells if c[1] == seed and c[0] in ("m1", "m2")], axis=0)
        truth = np.repeat([False, False, True, True], 3)
        acc = votes[(votes["seed"] == seed) & (votes["history"] == 1)]["accuracy"].item()
        assert acc == pytest.approx(np.mean(np.where(p > 0.5, True, False) == truth)) or (
            np.isclose(p, 0.5).any())


def test_merge_refuses_a_cell_that_two_folders_hold_at_different_histories(tmp_path, capsys):
    # a rerun of m1 seed 0 asking history 10 beside the history-1 run: the same cell (its
    # predictions twice); it passed the check and the vote stopped on a traceback
    # ('12 window(s) given more than once')
    pb = np.linspace(0.1, 0.9, 12)
    _folder(tmp_path / "a", [("m1", 0, pb), ("m2", 0, pb[::-1])])
    _folder(tmp_path / "b", [("m1", 0, pb)])
    cells = pd.read_csv(tmp_path / "b" / "compare_cells.csv")
    cells.assign(history=10).to_csv(tmp_path / "b" / "compare_cells.csv", index=False)
    code = _merge([tmp_path / "a", tmp_path / "b"], tmp_path / "out", "--vote", "m1", "m2",
                  "--history", "1")
    assert code == 2
    err = capsys.readouterr().err
    assert "a cell is in more than one folder" in err and "m1" in err and "seed 0" in err
    assert not (tmp_path / "out").exists()


def test_merge_says_where_a_vote_was_left_out_for_a_missing_member(tmp_path, capsys):
    # '--vote m1 m9' (m9 in no folder) wrote no vote row and said nothing
    pb = np.linspace(0.1, 0.9, 12)
    _folder(tmp_path / "a", [("m1", 0, pb), ("m2", 0, pb), ("m1", 1, pb)])
    _folder(tmp_path / "b", [("m2", 1, pb[::-1])])
    assert _merge([tmp_path / "a", tmp_path / "b"], tmp_path / "out", "--vote", "m1", "m9",
                  "--vote", "m1", "m2", "--history", "1") == 0
    out = capsys.readouterr().out
    assert ("note: vote(m1+m9) left out at 2 of 2 (protocol, dataset, signals, window_s, "
            "train_hop_s, seed): no m9 predictions there") in out
    assert "vote(m1+m2) left out" not in out
    models = pd.read_csv(tmp_path / "out" / "compare_cells.csv")["model"]
    assert (models == "vote(m1+m2)").sum() == 2 and not (models == "vote(m1+m9)").any()


def test_a_vote_over_folders_of_two_datasets_uses_each_datasets_own_classes(tmp_path):
    # the toy2 rows leave toy's proba_A / proba_B empty and the other way round: a vote
    # over all four columns would be decided by missing values
    pb = np.array([0.2] * 6 + [0.8] * 6)
    for name, model in (("a", "m1"), ("b", "m2")):
        _folder(tmp_path / name, [(model, 0, pb)])
        preds = pd.read_csv(tmp_path / name / "predictions.csv")
        other = preds.rename(columns={"proba_A": "proba_C", "proba_B": "proba_D"}).assign(
            dataset="toy2", true=preds["true"].map({"A": "C", "B": "D"}))
        pd.concat([preds, other]).to_csv(tmp_path / name / "predictions.csv", index=False)
        cells = pd.read_csv(tmp_path / name / "compare_cells.csv")
        pd.concat([cells, cells.assign(dataset="toy2")]).to_csv(
            tmp_path / name / "compare_cells.csv", index=False)
    assert _merge([tmp_path / "a", tmp_path / "b"], tmp_path / "out", "--vote", "m1", "m2",
                  "--history", "1") == 0
    merged = pd.read_csv(tmp_path / "out" / "compare_cells.csv")
    votes = merged[merged["model"] == "vote(m1+m2)"].set_index("dataset")
    assert votes.loc["toy", "accuracy"] == pytest.approx(1.0)
    assert votes.loc["toy2", "accuracy"] == pytest.approx(1.0)
