"""The nested rule choice of benchmarks/stream_reset_nested.py (no classifier trained)."""

from __future__ import annotations

import runpy
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
