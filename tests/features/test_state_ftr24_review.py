"""State review (ftr24): the windowing, feature and run-reading steps leave what they are
given unchanged, return objects of their own (a caller editing a result does not edit the
input, a cache or the next result), and transformers forget a first fit."""

from __future__ import annotations

import copy
import pickle
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings, strategies as st
from sklearn.base import clone

from features.ekf_signals import add_ekf_channels
from features.slip_features import SLIP_CHANNELS, slip_features
from features.transformers import WindowFeatures
from features.wheel_physics import WheelPhysicsFeatures
from features.windows import (ALL_CHANNELS, WindowConfig, WindowSet, add_derived_channels,
                              make_windows, window_frame)
from terrain.io.align import align_arrays, align_streams
from terrain.io.plausibility import check_run
from terrain.io.report import input_report
from terrain.io.shipped import read_shipped
from terrain.io.writer import to_file_frames
from terrain.run import Run
from terrain.vehicles import HUSKY


def _run(seed: int = 0, run_id: str = "test/ASPHALT/00") -> Run:
    """12 s of a Husky: a 100 Hz IMU and a 10 Hz wheel stream (noisy, turning)."""
    rng = np.random.default_rng(seed)
    t = np.arange(1200) / 100.0
    imu = pd.DataFrame({"t_s": t, **{c: 0.01 * rng.standard_normal(t.size)
                                     for c in ("wx", "wy", "ax", "ay")},
                        "wz": 0.2 + 0.01 * rng.standard_normal(t.size),
                        "az": 9.81 + 0.1 * rng.standard_normal(t.size)})
    tw = t[::10]
    wheels = pd.DataFrame({"t_s": tw, "vel_l": 0.5 + 0.01 * rng.standard_normal(tw.size),
                           "vel_r": 0.6 + 0.01 * rng.standard_normal(tw.size),
                           "cur_l": 5.0 + rng.standard_normal(tw.size),
                           "cur_r": 6.0 + rng.standard_normal(tw.size)})
    return Run(run_id=run_id, dataset="test", terrain="ASPHALT",
               streams={"imu": imu, "wheels": wheels}, source="in-memory test run",
               meta={"gaps": {"wheels": [(1.0, 1.5)]}, "repaired": {"imu.wz": 1},
                     "warnings": ["found"], "stuck": {}})


def _assert_run_unchanged(run: Run, before: Run) -> None:
    assert list(run.streams) == list(before.streams)
    for name, frame in run.streams.items():
        pd.testing.assert_frame_equal(frame, before.streams[name], check_exact=True)
        assert frame.attrs == before.streams[name].attrs
    assert run.meta == before.meta


CALLS = {
    "align_streams": lambda run: align_streams(run),
    "make_windows": lambda run: make_windows([run], "all", WindowConfig(rate_hz=50.0)),
    "make_windows_ekf": lambda run: make_windows([run], ("wz", "ekf_v_bx", "vel_diff"),
                                                 WindowConfig(rate_hz=50.0, steady_only=True)),
    "check_run": lambda run: check_run(run.run_id, run.streams, "husky", {}),
    "input_report": lambda run: input_report([run]),
    "to_file_frames": lambda run: to_file_frames(run),
}


@pytest.mark.parametrize("name", list(CALLS))
def test_run_steps_leave_the_run_unchanged(name):
    run = _run()
    before = copy.deepcopy(run)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        CALLS[name](run)
    _assert_run_unchanged(run, before)


def test_frame_steps_leave_the_aligned_frame_unchanged_and_return_their_own():
    frame = align_streams(_run())
    before = frame.copy(deep=True)
    derived = add_derived_channels(frame)
    ekf = add_ekf_channels(derived, wheel_rate_hz=10.0)
    X, *_ = window_frame(ekf, ("wz", "vel_l", "ekf_v_bx"), WindowConfig(rate_hz=50.0))
    pd.testing.assert_frame_equal(frame, before, check_exact=True)
    # the results are copies: editing them edits neither the frame nor each other
    derived["vel_l"] = -1.0
    ekf["wz"] = -1.0
    X[:] = -1.0
    pd.testing.assert_frame_equal(frame, before, check_exact=True)
    assert (add_ekf_channels(add_derived_channels(frame), wheel_rate_hz=10.0)["wz"]
            .to_numpy() != -1.0).any()


def test_align_arrays_leaves_a_filtered_stream_unchanged():
    # a 200 Hz stream on a 50 Hz clock is low-passed first: on a copy, not on the input
    t = np.arange(400) / 200.0
    v = np.random.default_rng(1).standard_normal((t.size, 2))
    grid = np.arange(1, 90) / 50.0
    before = v.copy()
    align_arrays([t], [v], grid, 50.0)
    np.testing.assert_array_equal(v, before)


def test_shipped_runs_are_read_anew_each_time(data_dir):
    # the reader keeps no frame: editing a run read does not edit the next read
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        first = read_shipped("vulpi", data_dir)
        reference = copy.deepcopy(first[0])
        first[0].streams["wheels"].iloc[:, 1] = -99.0
        first[0].meta["warnings"].append("edited")
        first[0].meta["gaps"]["edited"] = []
        second = read_shipped("vulpi", data_dir)
    _assert_run_unchanged(second[0], reference)
    assert second[0].meta is not first[0].meta


def _window_set() -> WindowSet:
    return make_windows([_run(0, "test/ASPHALT/00"), _run(1, "test/ASPHALT/01")], "all",
                        WindowConfig(rate_hz=50.0, window_s=1.0))


@settings(max_examples=15, deadline=None)
@given(data=st.data())
def test_window_set_subset_is_independent(data):
    ws = _window_set()
    before = copy.deepcopy(ws)
    n = len(ws)
    rows = np.asarray(data.draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=n)))
    mask = data.draw(st.sampled_from([rows, np.isin(np.arange(n), rows)]))
    sub = ws.subset(mask)
    for field in ("X", "run_ids", "groups", "labels", "t_start_s", "t_end_s"):
        getattr(sub, field)[...] = 0
    sub.counts["per_run"]["test/ASPHALT/00"]["windows"] = -5
    sub.counts["skipped_runs"].append("x")
    for field in ("X", "run_ids", "groups", "labels", "t_start_s", "t_end_s"):
        np.testing.assert_array_equal(getattr(ws, field), getattr(before, field))
    assert ws.counts == before.counts


def test_slip_features_leave_the_probabilities_and_windows_unchanged():
    ws = make_windows([_run()], SLIP_CHANNELS, WindowConfig(rate_hz=50.0))
    probs = pd.DataFrame({"asphalt": np.full(len(ws), 0.25), "grass": np.full(len(ws), 0.5)})
    p_before, x_before = probs.copy(deep=True), ws.X.copy()
    slip_features(ws, HUSKY, probs)
    pd.testing.assert_frame_equal(probs, p_before, check_exact=True)
    np.testing.assert_array_equal(ws.X, x_before)


def _windows(n_samples: int, seed: int = 0) -> np.ndarray:
    return 1.0 + np.random.default_rng(seed).standard_normal((4, len(ALL_CHANNELS), n_samples))


TRANSFORMERS = {
    "window": lambda: WindowFeatures(rate_hz=50.0, band_width_hz=5.0),
    "physics": lambda: WheelPhysicsFeatures(channels=tuple(ALL_CHANNELS), rate_hz=50.0),
}


@pytest.mark.parametrize("name", list(TRANSFORMERS))
@settings(max_examples=10, deadline=None)
@given(first=st.integers(8, 120), second=st.integers(8, 120))
def test_transformer_refit_forgets_the_first_fit(name, first, second):
    X1, X2 = _windows(first, 1), _windows(second, 2)
    fresh = TRANSFORMERS[name]().fit(X2)
    refit = TRANSFORMERS[name]().fit(X1).fit(X2)
    np.testing.assert_array_equal(refit.get_feature_names_out(), fresh.get_feature_names_out())
    np.testing.assert_array_equal(refit.transform(X2), fresh.transform(X2))
    assert refit.n_samples_in_ == second


@pytest.mark.parametrize("name", list(TRANSFORMERS))
def test_transformer_copies_behave_alike_and_are_independent(name):
    X, other = _windows(100), _windows(60, 3)
    X_before = X.copy()
    est = TRANSFORMERS[name]().fit(X)
    out = est.transform(X)
    np.testing.assert_array_equal(X, X_before)
    for copied in (pickle.loads(pickle.dumps(est)), copy.deepcopy(est)):
        np.testing.assert_array_equal(copied.transform(X), out)
        copied.fit(other)     # refitting the copy leaves the original fitted as it was
    clone(est).fit(other)
    np.testing.assert_array_equal(est.transform(X), out)
    names = est.get_feature_names_out()
    names[0] = "edited"
    assert est.get_feature_names_out()[0] != "edited"


def test_library_calls_leave_numpy_global_random_state_alone():
    state = np.random.get_state()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ws = _window_set()
        WindowFeatures(rate_hz=50.0).fit_transform(ws.X)
    after = np.random.get_state()
    assert state[0] == after[0] and np.array_equal(state[1], after[1]) and state[2:] == after[2:]


@pytest.mark.parametrize("name, bad", [
    ("window", {"band_width_hz": 2.5, "stats": ("mean", "mean")}),   # refused after bands
    ("window", {"band_width_hz": 2.5, "min_speed_m_s": 0.0}),
    ("physics", {"short_s": 0.5, "ridge": -1.0}),
])
def test_refused_refit_leaves_the_first_fit(name, bad):
    X = _windows(100)
    est = TRANSFORMERS[name]().fit(X)
    out, names = est.transform(X), est.get_feature_names_out()
    # windows of another length are featured from the bands, not the stored band weights
    shorter = est.transform(X[:, :, :80]) if name == "window" else None
    good = {k: v for k, v in est.get_params().items() if k in bad}
    est.set_params(**bad)
    with pytest.raises(Exception):
        est.fit(X)
    est.set_params(**good)      # the settings of the first fit again: its state is intact
    np.testing.assert_array_equal(est.get_feature_names_out(), names)
    np.testing.assert_array_equal(est.transform(X), out)
    if shorter is not None:
        np.testing.assert_array_equal(est.transform(X[:, :, :80]), shorter)


@pytest.mark.parametrize("as_iterable", [iter, lambda runs: (r for r in runs)])
def test_make_windows_of_an_iterator_equals_that_of_a_list(as_iterable):
    # the duplicate-id check read the iterator to its end: no run was left to window, and
    # an empty WindowSet came back without a word
    runs = [_run(0, "t/A/00"), _run(1, "t/A/01")]
    config = WindowConfig(rate_hz=50.0)
    listed = make_windows(runs, "all", config)
    given = make_windows(as_iterable(runs), "all", config)
    assert len(listed) > 0
    np.testing.assert_array_equal(given.X, listed.X)
    np.testing.assert_array_equal(given.run_ids, listed.run_ids)
    assert given.counts == listed.counts


def _truth_run(seed: int, run_id: str) -> Run:
    """:func:`_run` with a ``truth`` stream (100 Hz) as the simulator writes one."""
    from terrain.terramechanics.catalogue import TERRAIN_NAMES

    run = _run(seed, run_id)
    t = run.streams["imu"]["t_s"].to_numpy()
    truth = pd.DataFrame({"t_s": t, "slip_1": 0.1 + 0 * t, "slip_2": 0.05 + 0 * t,
                          "yaw_rate": 0.2 + 0 * t, "v_by": 0 * t,
                          "terrain": np.full(t.size, TERRAIN_NAMES[0], dtype=object)})
    return Run(run_id=run.run_id, dataset=run.dataset, terrain=TERRAIN_NAMES[0],
               streams={**run.streams, "truth": truth}, source=run.source,
               meta={"scenario": "turn", "seed": seed})


@pytest.mark.parametrize("as_iterable", [iter, lambda runs: (r for r in runs)])
def test_slip_table_of_an_iterator_equals_that_of_a_list(as_iterable):
    # the windowing read the iterator to its end: the targets then found none of the runs
    from features.slip_features import slip_table
    from terrain.terramechanics.catalogue import TERRAIN_NAMES

    runs = [_truth_run(0, "sim/A/00"), _truth_run(1, "sim/A/01")]
    listed = slip_table(runs, HUSKY, TERRAIN_NAMES)
    given = slip_table(as_iterable(runs), HUSKY, TERRAIN_NAMES)
    assert len(listed[0]) > 0
    for a, b in zip(given, listed):
        pd.testing.assert_frame_equal(a, b, check_exact=True)
