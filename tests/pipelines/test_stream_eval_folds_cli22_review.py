"""Boundaries of ``terrain stream-eval --folds``: the largest fold count the held-out
streams take is refused or taken before any work (cli22 review)."""

from __future__ import annotations

import pytest
from cli_helpers import RecordingRun

from terrain.cli import main


class _Stop(Exception):
    """Raised by a stand-in where the command reached the work it stands for."""


def _reached(calls):
    def stand_in(*args, **kwargs):
        calls.append(args)
        raise _Stop()
    return stand_in


@pytest.fixture
def stubbed(monkeypatch, tmp_path):
    """``stream-eval`` with the wheel CV and the held-out streams replaced by recorders
    (the real BorealTC runs are read)."""
    import pipelines.stream_eval as stream_eval

    monkeypatch.chdir(tmp_path)
    calls = {"wheel_cv": [], "streams": []}
    monkeypatch.setattr(stream_eval, "window_cv", _reached(calls["wheel_cv"]))
    monkeypatch.setattr(stream_eval, "held_out_streams", _reached(calls["streams"]))
    monkeypatch.setattr(stream_eval, "tracked_run", RecordingRun())
    return calls


@pytest.mark.slow
def test_folds_beyond_the_largest_class_are_refused_before_the_wheel_cv(stubbed, capsys):
    """BorealTC's wheel streams come from 55 runs, the largest class (SNOW) 22 of them: a
    stratified split by run takes at most 22 folds. ``--folds 23`` passed the check
    ("at most one fold per run") and ran the whole wheel CV before the held-out streams
    refused it; it is now refused first, naming the option."""
    assert main(["stream-eval", "--part", "both", "--kinds", "wheels", "--seeds", "0",
                 "--folds", "23"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("terrain stream-eval: error: --folds 23") and "22" in err
    assert stubbed == {"wheel_cv": [], "streams": []}


def test_a_fold_whose_stream_cannot_be_cut_is_refused_before_the_wheel_cv(stubbed, capsys):
    """Below the class limit, a fold may still hold too little for a stream (seed 0, 21
    folds: ASPHALT/02, 9.85 s, beside one other run): the streams' own refusal now comes
    before the wheel CV, naming --folds and the seed."""
    assert main(["stream-eval", "--part", "both", "--kinds", "wheels", "--seeds", "0",
                 "--folds", "21"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("terrain stream-eval: error: --folds 21 over the 55 runs the "
                          "wheels streams are cut from (seed 0): ")
    assert "borealtc/ASPHALT/02" in err
    assert stubbed == {"wheel_cv": [], "streams": []}


def test_the_largest_fold_count_reaches_the_wheel_cv(stubbed):
    """22 folds (the largest class's runs) with seed 0, whose every fold's stream is cut,
    is taken: the command reaches its work."""
    assert main(["stream-eval", "--part", "both", "--kinds", "wheels", "--seeds", "0",
                 "--folds", "22"]) == 1
    assert len(stubbed["wheel_cv"]) == 1
