"""The nested rule choice of benchmarks/stream_reset_nested.py (no classifier trained)."""

from __future__ import annotations

import json
import runpy
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "stream_reset_nested.py"


@pytest.fixture(scope="module")
def script():
    return runpy.run_path(str(SCRIPT))


def _row(accuracy: float, n: int = 100) -> dict:
    return {"accuracy": accuracy, "median_delay_s": 1.0, "n_switches": 1, "n_decisions": n,
            "accuracy_settled": accuracy, "n_settled": n, "delays_s": [1.0],
            "confusion": {"A": {"A": int(accuracy * n), "B": n - int(accuracy * n)}}}


def test_every_candidate_set_holds_the_default_once_and_only_scored_rules(script):
    rules, default = script["RULES"], script["DEFAULT_RULE"]
    for name, candidates in script["CANDIDATES"].items():
        assert candidates.count(default) == 1, name
        assert set(candidates) <= set(rules), name
        assert len(set(candidates)) == len(candidates), name
    # stream-eval's default-equal entry is scored once, under the default's name
    assert "dwell10_power0.5" not in rules
    assert set(script["CANDIDATES"]["all"]) == set(rules)


def test_each_fold_is_scored_with_the_rule_its_inner_streams_chose(script, capsys):
    rules = list(script["RULES"])
    default, other = script["DEFAULT_RULE"], "dwell30_power0.5"
    inner_tie = {r: 0.5 for r in rules}
    inner_other = {**inner_tie, other: 0.9}
    # fold 0: the inner streams prefer `other`, which is worse on the outer stream;
    # fold 1: a tie everywhere, so the default decides
    outer0 = {r: _row(0.8) for r in rules} | {other: _row(0.6)}
    outer1 = {r: _row(0.7) for r in rules} | {default: _row(0.9)}
    rows = [{"seed": 0, "fold": 0, "inner_accuracy": inner_other, "outer": outer0},
            {"seed": 0, "fold": 1, "inner_accuracy": inner_tie, "outer": outer1}]
    metrics = script["report"](rows)
    assert metrics["all_filter_accuracy"] == pytest.approx((0.8 + 0.9) / 2)
    assert metrics["all_nested_smoothing_accuracy"] == pytest.approx((0.6 + 0.9) / 2)
    assert metrics["all_nested_all_accuracy"] == pytest.approx((0.6 + 0.9) / 2)
    # `other` is no reset rule: the reset set keeps the default in both folds
    assert metrics["all_nested_reset_accuracy"] == pytest.approx((0.8 + 0.9) / 2)
    assert metrics["chosen_smoothing_dwell30_power0.5"] == 1.0
    assert metrics["chosen_smoothing_filter"] == 1.0
    assert metrics["chosen_reset_filter"] == 2.0
    assert "chosen among 'smoothing'" in capsys.readouterr().out


def _saved(tmp_path, name: str, seed: int, folds=(0, 1), **extra) -> Path:
    rules = list(runpy.run_path(str(SCRIPT))["RULES"])
    rows = [{"seed": seed, "fold": f, "inner_accuracy": {r: 0.5 for r in rules},
             "outer": {r: _row(0.8) for r in rules}} for f in folds]
    path = tmp_path / name
    path.write_text(json.dumps({"kind": "wheels", "rows": rows, **extra}))
    return path


def test_merge_refuses_a_seed_fold_held_by_two_files(script, tmp_path, monkeypatch, capsys):
    # the same seed saved twice (a rerun beside the first) counted every fold twice
    a = _saved(tmp_path, "a.json", 0)
    b = _saved(tmp_path, "b.json", 0, folds=(1,))
    monkeypatch.setattr(sys, "argv", ["stream_reset_nested.py", "--merge", str(a), str(b),
                                      "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert "seed 0 fold 1" in str(stop.value)
    assert "a.json" in str(stop.value) and "b.json" in str(stop.value)
    assert "seeds [0]" not in capsys.readouterr().out


def test_merge_takes_the_inner_folds_of_the_files(script, tmp_path):
    a = _saved(tmp_path, "a.json", 0, inner_folds=3)
    b = _saved(tmp_path, "b.json", 1, inner_folds=3)
    kind, inner, rows = script["merged_rows"]([a, b])
    assert (kind, inner, len(rows)) == ("wheels", 3, 4)
    c = _saved(tmp_path, "c.json", 2, inner_folds=4)
    with pytest.raises(SystemExit, match="inner folds"):
        script["merged_rows"]([a, c])
    # files written before the count was kept say nothing of it
    assert script["merged_rows"]([_saved(tmp_path, "d.json", 3)])[1] is None


def test_out_files_keep_the_inner_folds_for_merge(script, tmp_path, monkeypatch):
    rules = list(script["RULES"])

    def run_seed(runs, recipe, seed, inner_folds, bar):
        return [{"seed": seed, "fold": 0, "inner_accuracy": {r: 0.5 for r in rules},
                 "outer": {r: _row(0.8) for r in rules}}]

    env = script["main"].__globals__
    monkeypatch.setitem(env, "run_seed", run_seed)
    monkeypatch.setitem(env, "load_dataset", lambda name: [])
    monkeypatch.setattr(sys, "argv", ["stream_reset_nested.py", "--kind", "wheels",
                                      "--seeds", "0", "--inner-folds", "3", "--out",
                                      str(tmp_path), "--no-mlflow"])
    assert script["main"]() == 0
    saved = tmp_path / "wheels_seed0.json"
    assert json.loads(saved.read_text())["inner_folds"] == 3
    assert script["merged_rows"]([saved])[:2] == ("wheels", 3)
