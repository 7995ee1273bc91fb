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


def test_soft_vote_gives_the_weighted_mean_of_the_members_probabilities():
    """Equal weights average the members' probabilities (each row still sums to 1); given
    weights are normalised; the vote is the class of the largest mean."""
    import numpy as np
    import pandas as pd

    from terrain.models.compare import soft_vote

    def member(p_a):
        return pd.DataFrame({"seed": 0, "fold": [0, 0], "run": ["r1", "r2"],
                             "t_start_s": [0.0, 0.0], "proba_a": p_a,
                             "proba_b": 1 - np.asarray(p_a)})

    one, two = member([0.9, 0.2]), member([0.3, 0.4])
    out = soft_vote([one, two], ["a", "b"])
    assert np.allclose(out["proba_a"], [0.6, 0.3])
    assert np.allclose(out[["proba_a", "proba_b"]].sum(axis=1), 1.0)
    assert out["predicted"].tolist() == ["a", "b"]
    weighted = soft_vote([one, two], ["a", "b"], weights=[3.0, 1.0])
    assert np.allclose(weighted["proba_a"], [0.75 * 0.9 + 0.25 * 0.3, 0.75 * 0.2 + 0.25 * 0.4])


def test_history_over_fewer_than_k_windows_and_ties():
    """Before ``k`` windows of a run exist, the decision averages those there are; a tie of
    mean probabilities goes to the first class in ``classes`` order (the alphabetical order
    the CV gives, as the run vote's ties)."""
    import numpy as np
    import pandas as pd

    from terrain.models.compare import history_predictions

    rows = pd.DataFrame({"group": ["r1"] * 3 + ["r2"], "t_start_s": [0.0, 1.0, 2.0, 0.0],
                         "proba_a": [0.4, 0.6, 0.2, 0.5], "proba_b": [0.6, 0.4, 0.8, 0.5]})
    # r1, k = 5: mean of 1, 2 then 3 windows: b (0.6), tie 0.5/0.5 -> a, b (0.4 vs 0.6)
    # r2: its own first window, a tie -> a
    assert history_predictions(rows, ["a", "b"], 5).tolist() == ["b", "a", "b", "a"]
    assert history_predictions(rows, ["b", "a"], 5).tolist() == ["b", "b", "b", "b"]
    assert np.array_equal(history_predictions(rows, ["a", "b"], 1), ["b", "a", "b", "a"])


def test_params_log_the_effective_hop_of_non_overlapping_windows():
    """``as_params`` logs the effective hop: the window length when ``hop_s`` is unset
    (non-overlapping windows), and the same for an unset ``train_hop_s``; ``n_threads``
    None is 0 and the lists are comma-joined."""
    from terrain.models.experiment import ExperimentConfig

    params = ExperimentConfig(window_s=2.0, seeds=(0, 3)).as_params()
    assert params["hop_s"] == 2.0 and params["train_hop_s"] == 2.0
    assert params["seeds"] == "0,3" and params["n_threads"] == 0
    dense = ExperimentConfig(window_s=2.0, hop_s=1.0, train_hop_s=0.5).as_params()
    assert dense["hop_s"] == 1.0 and dense["train_hop_s"] == 0.5


def test_inference_latency_is_in_milliseconds_per_window():
    """``inference_ms_per_window`` times one window per call, in ms (a stand-in that takes
    about 3 ms a call gives about 3, not 0.003), and falls back to ``predict`` where
    ``predict_proba`` is missing."""
    import time

    import numpy as np

    from terrain.models.cv import inference_ms_per_window

    class Slow:
        def __init__(self):
            self.sizes = []

        def predict(self, X):
            self.sizes.append(len(X))
            time.sleep(0.003)
            return np.zeros(len(X))

    model = Slow()
    ms = inference_ms_per_window(model, np.zeros((10, 2)), 4)
    assert 2.5 <= ms < 100.0
    assert model.sizes == [1] * 5                      # warm-up and 4 timed, one window each
    # nothing to time: refused (the median of no time was NaN with a NumPy warning)
    from terrain.errors import ConfigError
    for X, n in ((np.zeros((10, 2)), 0), (np.zeros((0, 2)), 4), (np.zeros((10, 2)), True)):
        with pytest.raises(ConfigError, match="inference_ms_per_window"):
            inference_ms_per_window(model, X, n)


def test_confusion_figure_normalises_each_true_class_row():
    """``plot_confusion`` colours each cell by its share of the true class (row), a class
    without windows stays 0, and the counts are kept in the cell text."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from terrain.models.metrics import confusion, plot_confusion

    cm = confusion(["a", "a", "a", "a", "b", "b"], ["a", "a", "a", "b", "b", "b"],
                   ["a", "b", "c"])
    fig = plot_confusion(cm, "t")
    shown = np.asarray(fig.axes[0].images[0].get_array())
    assert np.allclose(shown, [[0.75, 0.25, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    assert "3\n0.75" in [t.get_text() for t in fig.axes[0].texts]
    plt.close(fig)


def test_an_inner_split_over_exactly_as_many_runs_as_folds_is_accepted():
    """``require_runs`` refuses fewer runs than inner folds, naming them and the setting; as
    many runs as folds is enough (each fold holds one out)."""
    from terrain.models.cv import require_runs

    require_runs(["r1", "r2", "r3", "r1"], 3, "early stopping", "ModelConfig.inner_splits")
    with pytest.raises(ConfigError, match=r"3 inner folds \(ModelConfig.inner_splits\): it "
                                          r"got 2 runs \(.*r1.*r2.*\) and needs at least 3"):
        require_runs(["r1", "r2", "r1"], 3, "early stopping", "ModelConfig.inner_splits")
