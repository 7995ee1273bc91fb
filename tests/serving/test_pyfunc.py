"""The aligned-samples pyfunc (:func:`terrain.serving.pyfunc.predict_windows`) refuses input
that is not numbers with the project's typed errors, on a stand-in classifier."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig
from terrain.errors import ImplausibleValueError, NonNumericError
from terrain.serving.pyfunc import predict_windows, save_model


class _Classifier:
    classes_ = np.array(["A", "B"])

    def predict_proba(self, X):
        return np.tile([0.3, 0.7], (len(X), 1))


def _predict(samples):
    return predict_windows(_Classifier(), samples, ["vel_l", "vel_r"],
                           WindowConfig(window_s=2.0, rate_hz=20.0), ["A", "B"])


def _samples(n=200):
    """10 s of aligned wheel samples of one run at 20 Hz."""
    return pd.DataFrame({"run": "r1", "t_s": np.arange(n) / 20.0, "vel_l": 0.5, "vel_r": 0.5})


@pytest.mark.parametrize("column, cell", [("t_s", "x"), ("vel_l", "x"), ("vel_l", True)])
def test_a_cell_that_is_not_a_number_is_a_typed_error_naming_it(column, cell):
    # text was Python's bare "ValueError: could not convert string to float: 'x'", and a
    # JSON true was read as 1.0 m/s
    samples = _samples().astype({column: object})
    samples.loc[7, column] = cell
    with pytest.raises(NonNumericError) as exc:
        _predict(samples)
    assert exc.value.column == column and exc.value.row == 7


def test_integer_values_are_range_checked_like_floats():
    # 1000 m/s written as integers passed the plausibility ranges (they look at float
    # columns only) and gave five confident windows
    samples = _samples()
    samples["vel_l"] = 1000
    with pytest.raises(ImplausibleValueError, match="vel_l"):
        _predict(samples)
    assert len(_predict(_samples())) == 5


def test_a_run_shorter_than_a_window_is_listed_not_left_out_unsaid():
    # r2 (0.5 s, the window is 2 s) gave no row and no count
    short = _samples(10).assign(run="r2")
    out = _predict(pd.concat([_samples(), short], ignore_index=True))
    assert set(out["run"]) == {"r1"} and len(out) == 5
    assert out.attrs["short_runs"] == ["r2"]
    assert _predict(_samples()).attrs["short_runs"] == []


@pytest.mark.filterwarnings("ignore:.*An input example was not provided")
def test_mlflow_drops_extra_input_columns_before_predict_and_logs_them(tmp_path, monkeypatch):
    # terrain serve names a request's columns that no stream has (ignored_columns); the
    # aligned-samples pyfunc cannot: MLflow's signature enforcement removes the columns its
    # input schema lacks before TerrainModel.predict runs, and logs them as a warning of its
    # own (documented in the module docstring and README), so predict_windows never sees them
    import logging

    import mlflow.pyfunc
    from sklearn.dummy import DummyClassifier

    from terrain.serving import pyfunc

    clf = DummyClassifier(strategy="prior").fit(np.zeros((4, 2, 40)), ["A", "A", "B", "B"])
    save_model(tmp_path / "m", clf, ["vel_l", "vel_r"], WindowConfig(window_s=2.0, rate_hz=20.0),
               ["A", "B"], {}, progress=False)
    model = mlflow.pyfunc.load_model(str(tmp_path / "m"))
    seen = []

    def spy(pipeline, samples, *args):
        seen.append(list(samples.columns))
        return predict_windows(pipeline, samples, *args)

    monkeypatch.setattr(pyfunc, "predict_windows", spy)
    records = []
    handler = logging.Handler()
    handler.emit = records.append
    logger = logging.getLogger("mlflow.models.utils")
    logger.addHandler(handler)
    try:
        out = model.predict(_samples().assign(**{"Unnamed: 0": 1.0, "gps_lat": 46.8}))
    finally:
        logger.removeHandler(handler)
    assert seen == [["run", "t_s", "vel_l", "vel_r"]]
    pd.testing.assert_frame_equal(out, model.predict(_samples()))
    assert any("'Unnamed: 0'" in r.getMessage() and "'gps_lat'" in r.getMessage()
               and "will be ignored" in r.getMessage() for r in records)


@pytest.mark.filterwarnings("ignore:.*An input example was not provided")
def test_a_save_interrupted_midway_leaves_no_half_written_model_directory(tmp_path,
                                                                          monkeypatch):
    # Was: an interrupt while MLflow wrote MLmodel left 'artifacts' and 'pyfunc_entry.py'
    # in the target, so the next save refused the folder ("exists and is not empty") and a
    # load met half a model. Now the folder appears whole or not at all.
    import mlflow.models.model
    from sklearn.dummy import DummyClassifier

    from terrain.errors import ConfigError

    def interrupted(self, *args, **kwargs):
        raise KeyboardInterrupt("interrupted while writing MLmodel")

    clf = DummyClassifier(strategy="prior").fit(np.zeros((4, 2, 40)), ["A", "A", "B", "B"])
    args = (clf, ["vel_l", "vel_r"], WindowConfig(window_s=2.0, rate_hz=20.0), ["A", "B"], {})
    (tmp_path / "m").mkdir()                         # an empty target is accepted
    with monkeypatch.context() as patch:
        patch.setattr(mlflow.models.model.Model, "save", interrupted)
        with pytest.raises(KeyboardInterrupt):
            save_model(tmp_path / "m", *args, progress=False)
    assert [p.name for p in tmp_path.iterdir()] == ["m"]     # no staging folder left
    assert not any((tmp_path / "m").iterdir())               # and nothing half-written
    save_model(tmp_path / "m", *args, progress=False)        # so a second try succeeds
    assert (tmp_path / "m" / "MLmodel").is_file()
    with pytest.raises(ConfigError, match="exists and is not empty"):
        save_model(tmp_path / "m", *args, progress=False)
