"""The oracle rules of benchmarks/stream_switch_oracle.py (no classifier trained)."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

from terrain.serving.evaluation import Segment

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "stream_switch_oracle.py"


@pytest.fixture(scope="module")
def script():
    return runpy.run_path(str(SCRIPT))


def _proba(n_a: int, n_b: int) -> np.ndarray:
    """n_a confident windows of class 0, then n_b of class 1 (0.8 / 0.2)."""
    return np.r_[np.tile([0.8, 0.2], (n_a, 1)), np.tile([0.2, 0.8], (n_b, 1))]


def test_a_restart_forgets_the_old_terrain(script):
    proba = _proba(60, 20)
    never = script["decide"](proba, np.zeros(80, dtype=bool))
    restart = np.zeros(80, dtype=bool)
    restart[60] = True
    oracle = script["decide"](proba, restart)
    np.testing.assert_array_equal(oracle[:60], never[:60])
    # from a uniform belief the first window of class 1 decides it; the filter that
    # carried 30 s of class 0 still says 0 there
    assert oracle[60] == 1 and never[60] == 0
    first = int(np.argmax(never[60:] == 1))
    assert first > 0 and (oracle[60:] == 1).all()


def test_the_oracle_restarts_at_the_first_window_wholly_in_the_new_piece(script,
                                                                         monkeypatch):
    # 30 s of A then 10 s of B, a decision every 0.5 s, 2 s windows: the first window
    # wholly in B ends at t = 32.0
    seen = []

    def decide(proba, restart):
        seen.append(restart.copy())
        return np.zeros(len(proba), dtype=int)

    monkeypatch.setitem(script["rules"].__globals__, "decide", decide)
    t = np.arange(2.0, 40.0, 0.5)
    segments = [Segment("a/A/0", "A", 0.0, 0.0, 30.0), Segment("b/B/0", "B", 0.0, 30.0, 10.0)]
    fold = {"proba": _proba(int(np.sum(t < 30.0)), int(np.sum(t >= 30.0))), "t": t,
            "segments": segments, "window_s": 2.0}
    script["rules"](fold)
    (restart,) = seen
    np.testing.assert_array_equal(t[restart], [32.0])


def test_every_printed_score_is_logged(script, monkeypatch, capsys):
    # settled accuracy and median delay were printed per rule, only the accuracy logged
    scores = {"raw": (0.80, 0.85, 1.0), "filter": (0.86, 0.90, 4.0),
              "oracle restart": (0.88, 0.92, 2.0), "oracle hybrid": (0.89, 0.92, 1.5),
              "reset(0.9, 2)": (0.87, 0.91, 3.0)}
    monkeypatch.setitem(script["report"].__globals__, "pooled",
                        lambda folds, rule: scores[rule])
    metrics = script["report"]({0: [{}], 1: [{}]}, [0, 1], "reset(0.9, 2)")
    for label in ("all", "first", "rest"):
        assert metrics[f"{label}_filter_accuracy"] == 0.86
        assert metrics[f"{label}_oracle_restart_accuracy_settled"] == 0.92
        assert metrics[f"{label}_reset_0.9_2_median_delay_s"] == 3.0
    assert len(metrics) == 3 * 5 * 3
    assert "settled 0.9100  median delay 3.00 s" in capsys.readouterr().out
