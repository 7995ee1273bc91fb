"""terrain.process_state.SharedSetting: the first of overlapping calls saves a process-wide
setting, the last to leave puts it back, whatever the order in which they leave."""

from __future__ import annotations

import os
import threading

import pytest

from terrain.process_state import SharedSetting, environment_variable

NAME = "TERRAIN_TEST_SHARED_SETTING"


def test_the_variable_is_set_inside_and_as_before_after(monkeypatch):
    monkeypatch.setenv(NAME, "before")
    setting = environment_variable(NAME, "inside")
    with setting:
        assert os.environ[NAME] == "inside"
    assert os.environ[NAME] == "before"
    monkeypatch.delenv(NAME)
    with setting:
        assert os.environ[NAME] == "inside"
    assert NAME not in os.environ


def test_a_call_raising_inside_still_restores(monkeypatch):
    monkeypatch.delenv(NAME, raising=False)
    setting = environment_variable(NAME, "inside")
    with pytest.raises(RuntimeError):
        with setting:
            raise RuntimeError("the call failed")
    assert NAME not in os.environ


@pytest.mark.parametrize("first_leaves_first", [True, False])
def test_overlapping_calls_restore_what_the_first_found_at_the_last_leave(monkeypatch,
                                                                          first_leaves_first):
    # each call restoring what *it* found: the second found "inside" and put that back
    monkeypatch.setenv(NAME, "before")
    setting = environment_variable(NAME, "inside")
    first, second = threading.Event(), threading.Event()
    entered = threading.Barrier(3)
    seen = []

    def call(leave):
        with setting:
            entered.wait()
            leave.wait()
            seen.append(os.environ[NAME])

    threads = [threading.Thread(target=call, args=(e,), daemon=True) for e in (first, second)]
    for t in threads:
        t.start()
    entered.wait(timeout=10)
    order = (first, second) if first_leaves_first else (second, first)
    try:
        order[0].set()
        threads[0 if first_leaves_first else 1].join(timeout=10)
        still_inside = os.environ.get(NAME)
    finally:
        order[1].set()          # never leave a thread waiting (a failure would hang pytest)
        for t in threads:
            t.join(timeout=10)
    assert still_inside == "inside"     # one call was still inside
    assert seen == ["inside", "inside"]
    assert os.environ[NAME] == "before"


def test_a_failed_apply_restores_and_leaves_nobody_inside():
    state = {"value": "before", "restored": 0}

    def apply(saved):
        state["value"] = "half-changed"
        raise ValueError("refused")

    def restore(saved):
        state["value"] = saved
        state["restored"] += 1

    setting = SharedSetting(lambda: state["value"], apply, restore)
    with pytest.raises(ValueError, match="refused"):
        with setting:
            pass
    assert state == {"value": "before", "restored": 1}
    # the next call saves afresh (the failed one is not counted inside)
    state["value"] = "later"
    setting2_calls = []
    setting._apply = lambda saved: setting2_calls.append(saved)
    with setting:
        pass
    assert setting2_calls == ["later"] and state["value"] == "later"


def test_nested_calls_restore_at_the_outer_leave(monkeypatch):
    monkeypatch.delenv(NAME, raising=False)
    setting = environment_variable(NAME, "inside")
    with setting:
        with setting:
            pass
        assert os.environ[NAME] == "inside"
    assert NAME not in os.environ
