"""State, aliasing and reuse of the window models (review mdl24).

Hidden global state: a fit must leave the caller's random streams (NumPy's global
generator) as it found them; inputs are not modified; copies are independent.
"""

import numpy as np
import pytest

pytest.importorskip("aeon")

from terrain.models.minirocket import MiniRocketFeatures, make_minirocket  # noqa: E402


def _windows(seed=0, n=12, channels=2, samples=20):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, channels, samples))
    y = np.repeat(["a", "b", "c"], n // 3)
    return X, y


@pytest.mark.parametrize("prior", [0, 123])
def test_minirocket_fit_leaves_numpy_global_random_state_alone(prior):
    """aeon's MiniRocket reseeds ``np.random`` with its seed: the caller's next draw was
    the seed's, whatever the stream was before the fit."""
    X, _ = _windows()
    np.random.seed(prior)
    expected = np.random.random(3)
    np.random.seed(prior)
    MiniRocketFeatures(n_kernels=84, random_state=5).fit(X)
    np.testing.assert_array_equal(np.random.random(3), expected)


def test_minirocket_pipeline_fit_leaves_numpy_global_random_state_alone():
    X, y = _windows()
    np.random.seed(7)
    expected = np.random.random(3)
    np.random.seed(7)
    make_minirocket(random_state=3, n_kernels=84).fit(X, y)
    np.testing.assert_array_equal(np.random.random(3), expected)


def test_minirocket_features_do_not_depend_on_numpy_global_random_state():
    X, _ = _windows()
    np.random.seed(1)
    a = MiniRocketFeatures(n_kernels=84, random_state=5).fit(X).transform(X)
    np.random.seed(2)
    b = MiniRocketFeatures(n_kernels=84, random_state=5).fit(X).transform(X)
    np.testing.assert_array_equal(a, b)


def _flat(X):
    X = np.asarray(X, dtype=float)
    return X.reshape(len(X), -1)


def _member():
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import FunctionTransformer
    return make_pipeline(FunctionTransformer(_flat), LogisticRegression())


def _refit_on_one_axis(make):
    rng = np.random.default_rng(0)
    X = rng.normal(size=(12, 3))
    y = np.repeat(["a", "b"], 6)
    groups = np.repeat(["r1", "r2", "r3", "r4"], 3)
    refitted = make().fit(X, y, groups).fit(X[:, 0], y, groups)
    fresh = make().fit(X[:, 0], y, groups)
    return refitted, fresh


@pytest.mark.parametrize("kind", ["ensemble", "run_balanced"])
def test_a_refit_on_input_without_a_second_axis_forgets_the_first_width(kind):
    """A second fit on (n_windows,) input kept n_features_in_ of the first fit's 2-D
    input: the refitted model claimed a width its members never saw."""
    from terrain.models.ensemble import SoftVotingEnsemble
    from terrain.models.weighting import run_balanced
    make = {"ensemble": lambda: SoftVotingEnsemble([("m", _member())], weights=[1.0]),
            "run_balanced": lambda: run_balanced(_member())}[kind]
    refitted, fresh = _refit_on_one_axis(make)
    assert not hasattr(fresh, "n_features_in_")
    assert not hasattr(refitted, "n_features_in_")


def _configs():
    from terrain.models.compare import CompareConfig
    from terrain.models.experiment import ExperimentConfig
    from terrain.models.registry import ModelConfig
    from terrain.models.svm import SVMConfig
    return [
        (SVMConfig, {"search_C": [3.0, 10.0], "search_gamma": ["scale", 0.01]}),
        (ModelConfig, {"kind": "ensemble", "ensemble_members": ["svm", "minirocket"]}),
        (ExperimentConfig, {"signals": ["imu", "wheels"], "seeds": [0, 1]}),
        (CompareConfig, {"models": ["svm"], "signals": ["imu"], "windows_s": [2.0],
                         "datasets": ["borealtc"], "seeds": [0], "history": [1, 5]}),
    ]


@pytest.mark.parametrize("make, lists", _configs(),
                         ids=lambda v: getattr(v, "__name__", ""))
def test_a_frozen_config_does_not_hold_the_callers_list(make, lists):
    """A list handed to a frozen config was kept as it was: the caller's later change to
    it changed the validated config (an ensemble member given twice, a repeated seed), the
    config was unhashable and unequal to the same config built from tuples."""
    import copy
    given = copy.deepcopy(lists)
    config = make(**given)
    same = make(**{k: tuple(v) if isinstance(v, list) else v for k, v in lists.items()})
    assert config == same
    assert hash(config) == hash(same)
    for value in given.values():
        if isinstance(value, list):
            value.append(value[0])      # the caller reuses its list
    assert config == same
    for name, value in lists.items():
        if isinstance(value, list):
            assert getattr(config, name) == tuple(value)


def test_a_forest_grown_by_a_warm_start_refit_is_repacked():
    """A warm-start refit of the final forest appends trees to the same estimators_ list:
    the packed trees, keyed on that list alone, stayed those of the first fit and the
    compiled predict_proba averaged the old trees only."""
    from sklearn.ensemble import ExtraTreesClassifier
    from sklearn.preprocessing import StandardScaler
    from terrain.models.forest import ForestPipeline
    rng = np.random.default_rng(0)
    X, Xn = rng.normal(size=(60, 4)), rng.normal(size=(20, 4))
    y = np.repeat(["a", "b", "c"], 20)
    pipe = ForestPipeline([("scale", StandardScaler()),
                           ("trees", ExtraTreesClassifier(n_estimators=5, random_state=0))])
    pipe.fit(X, y)
    pipe.predict_proba(Xn)
    forest = pipe.steps[-1][1]
    forest.set_params(warm_start=True, n_estimators=10).fit(pipe[:-1].transform(X), y)
    assert len(forest.estimators_) == 10
    np.testing.assert_allclose(pipe.predict_proba(Xn),
                               forest.predict_proba(pipe[:-1].transform(Xn)), atol=1e-12)


def _compiled_pipelines():
    from sklearn.ensemble import ExtraTreesClassifier
    from features.transformers import WindowFeatures
    from terrain.models.forest import ForestPipeline
    from terrain.models.svm import SVMConfig, svm_window_pipeline
    channels, rate = ("wz", "ax"), 20.0
    return {
        "svm": lambda: svm_window_pipeline(channels, rate, SVMConfig(probability=True)),
        "trees": lambda: ForestPipeline([("features", WindowFeatures(channels, rate)),
                                         ("trees", ExtraTreesClassifier(8, random_state=0))]),
        "minirocket": lambda: make_minirocket(n_kernels=84, max_dilations_per_kernel=4),
    }


@pytest.mark.parametrize("kind", ["svm", "trees", "minirocket"])
def test_a_deep_copy_refitted_elsewhere_leaves_the_original_and_interleaving_is_free(kind):
    """The fast paths cache fitted arrays on the pipeline: a deep copy refitted on other
    windows (fewer classes) must not change the original's probabilities, and two
    pipelines used alternately give what each gives alone."""
    import copy
    make = _compiled_pipelines()[kind]
    X, y = _windows(0, n=30)
    X2, y2 = _windows(1, n=30)
    X2, y2 = X2[y2 != "c"], y2[y2 != "c"]
    probe = _windows(2, n=9)[0]
    first = make().fit(X, y)
    expected = first.predict_proba(probe)
    twin = copy.deepcopy(first)
    np.testing.assert_array_equal(twin.predict_proba(probe), expected)
    twin.fit(X2, y2)
    assert list(twin.classes_) == ["a", "b"]
    np.testing.assert_array_equal(first.predict_proba(probe), expected)
    alone = make().fit(X2, y2).predict_proba(probe)
    np.testing.assert_allclose(twin.predict_proba(probe), alone, atol=1e-12)
    np.testing.assert_array_equal(first.predict(probe), first.classes_[expected.argmax(1)])


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_fast_path_leaves_the_callers_features_unchanged(dtype):
    """The scaler of the fast path standardises in place: on a copy, never on the
    caller's features (the first step here, so the caller's own array reaches it)."""
    from terrain.models.svm import SVMConfig, SVMPipeline, make_svm
    rng = np.random.default_rng(3)
    X = (rng.normal(size=(30, 4)) * 5 + 2).astype(dtype)
    y = np.repeat(["a", "b", "c"], 10)
    pipe = SVMPipeline(make_svm(SVMConfig(probability=True)).steps).fit(X, y)
    assert pipe._compiled() is not None
    before = X.copy()
    pipe.predict_proba(X)
    pipe.predict(X[:1])
    np.testing.assert_array_equal(X, before)
    assert X.dtype == dtype


def test_one_signal_name_given_as_text_is_the_one_name_tuple():
    # mdl24's left-alone: as_params joined the letters of "imu" ("i,m,u"), so the MLflow
    # param 'signals' of a library call named three unknown signals
    from terrain.models.experiment import ExperimentConfig

    text, one = ExperimentConfig(signals="imu"), ExperimentConfig(signals=("imu",))
    assert text == one and text.signals == ("imu",)
    assert text.as_params()["signals"] == "imu"
