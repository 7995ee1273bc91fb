"""Boundary of ``terrain train``'s default training hop against the window (cli22 review):
the per-dataset default (BorealTC 0.5 s) was meant to cut training windows more densely
than back to back; a window shorter than it must not leave samples out between them."""

from __future__ import annotations

import pytest
from cli_helpers import RecordingRun

from terrain.cli import main


class _Stop(Exception):
    """Raised by the stand-in of the fit, where the configuration is complete."""


@pytest.fixture
def fitted(monkeypatch, tmp_path):
    import pipelines.train as train

    configs = []

    def fit(config, runs, progress):
        configs.append(config)
        raise _Stop()

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(train, "load_dataset", lambda name: [])
    monkeypatch.setattr(train, "check_dependencies", lambda model: None)
    monkeypatch.setattr(train, "tracked_run", RecordingRun())
    monkeypatch.setattr(train, "fit_pipeline", fit)
    return configs


@pytest.mark.parametrize("window, hop", [("2", 0.5), ("0.5", 0.5), ("0.4", 0.4),
                                         ("0.25", 0.25)])
def test_the_default_hop_is_never_longer_than_the_window(fitted, window, hop):
    """2 s windows every 0.5 s (the measured default) unchanged; a 0.4 s window was cut
    every 0.5 s, a 0.1 s gap of every run's samples out of training between windows."""
    assert main(["train", "--dataset", "borealtc", "--window-s", window,
                 "--no-register", "--no-progress"]) == 1
    assert fitted[-1].train_hop_s == pytest.approx(hop)


def test_a_hop_given_longer_than_the_window_is_taken_as_given(fitted):
    assert main(["train", "--dataset", "borealtc", "--window-s", "0.4", "--train-hop-s",
                 "0.5", "--no-register", "--no-progress"]) == 1
    assert fitted[-1].train_hop_s == 0.5
