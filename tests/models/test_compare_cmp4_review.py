"""Review (cmp4) of the comparison grid, the CV metrics and their backends."""

import sys

import pytest

from terrain.errors import ConfigError
from terrain.models.compare import check_backend, joblib_backend


def test_the_dask_backend_without_distributed_is_a_config_error(monkeypatch):
    """``joblib_backend`` says a backend whose library is missing is a ConfigError; for
    ``dask`` it was Python's bare ModuleNotFoundError, raised after ``check_backend`` had
    passed it (so ``terrain compare`` had opened its MLflow run)."""
    monkeypatch.setitem(sys.modules, "distributed", None)   # import of it fails
    with pytest.raises(ConfigError, match="dask backend needs"):
        check_backend("dask", None)
    with pytest.raises(ConfigError, match="dask backend needs"):
        with joblib_backend("dask", "tcp://scheduler:8786"):
            pass


def test_a_groups_truth_is_its_first_windows_label_as_documented():
    """``run_majority_accuracy`` takes a group's true label from its first window (its
    docstring); the mean is over groups, not windows."""
    from terrain.models.metrics import run_majority_accuracy

    # r1: truth a (first window), vote b -> wrong; r2: truth b, vote b -> right
    assert run_majority_accuracy(["a", "b", "b", "b"], ["b", "b", "b", "b"],
                                 ["r1", "r1", "r1", "r2"]) == 0.5


def test_run_cv_times_the_training_cut_outside_the_cross_validation(vulpi_runs, monkeypatch):
    """``timings_s["cv_s"]`` is the cross-validation's time: the training cut of
    ``train_hop_s`` (its windows and features, here a stand-in that takes 0.4 s) was counted
    in it, not in ``features_s``."""
    import time

    import pandas as pd

    import terrain.models.experiment as experiment
    from terrain.models.cv import CVReport

    def slow_cut(*args, **kwargs):
        time.sleep(0.4)

    def no_cv(*args, **kwargs):
        empty = pd.DataFrame()
        return CVReport([], empty, empty, empty, empty)

    monkeypatch.setattr(experiment, "load_training_windows", slow_cut)
    monkeypatch.setattr(experiment, "cross_validate", no_cv)
    result = experiment.run_cv(experiment.ExperimentConfig(
        dataset="vulpi", signals=("wheels",), seeds=(0,)), runs=vulpi_runs)
    assert result.timings_s["cv_s"] < 0.3
    assert result.timings_s["features_s"] >= 0.4
