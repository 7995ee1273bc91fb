"""Review checks (ctl19) of the live-sim classifier's training axes
(pipelines/control_classifier.py): each terrain, seed and scenario once, each seed a whole
number, refused before any training run."""

from __future__ import annotations

import pytest

import pipelines.control_classifier as control_classifier
from terrain.errors import ConfigError


@pytest.mark.parametrize("kwargs, named", [
    (dict(terrains=["ICE", "ice"]), "terrains"),               # one terrain in two cases
    (dict(terrains=["ICE"], seeds=(2000, 2000)), "seeds"),
    (dict(terrains=["ICE"], scenarios=("orchard", "orchard")), "scenarios"),
    (dict(terrains=["ICE"], seeds=(2000.5,)), r"seeds\[0\]"),  # trained as seed 2000
    (dict(terrains=["ICE"], seeds=(True,)), r"seeds\[0\]"),
    (dict(terrains=["ICE"], seeds=("2000",)), r"seeds\[0\]")])
def test_the_training_axes_are_checked_before_any_run(tmp_path, monkeypatch, kwargs, named):
    """A terrain given twice (in any case), a repeated seed or scenario simulated the same
    training runs twice under one run id (their windows counted twice in the fit and the
    cache key another model's); a seed of 2000.5 trained on seed 2000 and said nothing, text
    stopped on Python's bare TypeError in the seed check. Each is now a ConfigError naming
    the axis, before any simulation."""
    runs = []
    monkeypatch.setattr(control_classifier, "simulate", lambda *a, **k: runs.append(a))
    monkeypatch.setattr(control_classifier, "run_closed_loop",
                        lambda *a, **k: runs.append(a))
    with pytest.raises(ConfigError, match=named):
        control_classifier.sim_classifier("husky", cache_dir=tmp_path, **kwargs)
    assert runs == [] and not any(tmp_path.iterdir())
