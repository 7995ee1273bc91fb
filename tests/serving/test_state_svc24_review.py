"""State, aliasing and reuse of the streaming service: inputs left as pushed, decisions that
own their probabilities, services that share nothing, copies that behave as the original."""

from __future__ import annotations

import copy
import pickle
from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import TerrainError
from terrain.run import WHEEL_CHANNELS
from terrain.serving.clocks import HeldChunks, HeldRun
from terrain.serving.config import StreamConfig
from terrain.serving.replay import replay_run
from terrain.serving.service import StreamService
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig
from terrain.serving.targets import CataloguePeakTargets, TableTargets


@pytest.fixture(scope="module")
def wheels(borealtc_runs, train_runs):
    """The first 12 s of the wheel stream of a run the models were not trained on."""
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.run_id not in seen)
    w = run.streams["wheels"]
    return w[w["t_s"] < w["t_s"].iloc[0] + 12.0].reset_index(drop=True)


def _service(model, **kwargs):
    return StreamService(model, CataloguePeakTargets(model.classes), StreamConfig(**kwargs))


def _chunks(frame, size):
    t = frame["t_s"].to_numpy(float)
    v = frame[list(WHEEL_CHANNELS)].to_numpy(float)
    return [(t[i:i + size], v[i:i + size]) for i in range(0, len(t), size)]


def _rows(decisions):
    return [(d.t_s, d.terrain, d.confidence, tuple(d.proba), d.target_slip_traction,
             d.window_age_s, d.flags) for d in decisions]


def _push_all(svc, chunks):
    out = []
    for t, v in chunks:
        out += svc.push("wheels", t, v)
    return out


def test_push_leaves_the_pushed_arrays_as_they_were(wheel_model, wheels):
    # a late stretch (a restart), a resent chunk and a step ahead all go through holds
    t = wheels["t_s"].to_numpy(float)
    v = wheels[list(WHEEL_CHANNELS)].to_numpy(float)
    svc = _service(wheel_model)
    pushes = [(t[:100], v[:100]), (t[90:160], v[90:160]), (t[:150] - 0.013, v[:150]),
              (t[160:] + 500.0, v[160:]), (t[160:200], v[160:200])]
    for ts, vs in pushes:
        for values in (vs, {c: vs[:, j] for j, c in enumerate(WHEEL_CHANNELS)},
                       pd.DataFrame(vs, columns=list(WHEEL_CHANNELS))):
            before_t, before_v = ts.copy(), copy.deepcopy(values)
            svc.push("wheels", ts, values)
            np.testing.assert_array_equal(ts, before_t)
            if isinstance(values, pd.DataFrame):
                pd.testing.assert_frame_equal(values, before_v)
            elif isinstance(values, dict):
                assert values.keys() == before_v.keys()
                for c in values:
                    np.testing.assert_array_equal(values[c], before_v[c])
            else:
                np.testing.assert_array_equal(values, before_v)


def test_a_reused_push_array_does_not_change_what_was_pushed(wheel_model, wheels):
    # a robot fills one array per push: overwriting it after a push changes no decision
    chunks = _chunks(wheels, 7)
    expected = _rows(_push_all(_service(wheel_model), chunks))
    svc, got = _service(wheel_model), []
    t_buf, v_buf = np.empty(7), np.empty((7, len(WHEEL_CHANNELS)))
    for t, v in chunks:
        n = len(t)
        t_buf[:n], v_buf[:n] = t, v
        got += svc.push("wheels", t_buf[:n], v_buf[:n])
        t_buf[:], v_buf[:] = -1.0, np.nan
    assert _rows(got) == expected


def test_a_reused_push_array_does_not_change_the_samples_held(wheel_model, wheels):
    # held while their clock is told: after a dropout (the timestamp_units rule) and as a
    # restarted clock (late samples running on)
    t = wheels["t_s"].to_numpy(float)
    v = wheels[list(WHEEL_CHANNELS)].to_numpy(float)
    pushes = [(t[:120], v[:120]), (t[120:] + 3.0, v[120:]), (t - 0.013, v * 1.01)]
    chunks = [(ts[i:i + 5], vs[i:i + 5]) for ts, vs in pushes for i in range(0, len(ts), 5)]
    fresh = _service(wheel_model)
    expected = _rows(_push_all(fresh, chunks))
    svc, got = _service(wheel_model), []
    t_buf, v_buf = np.empty(5), np.empty((5, len(WHEEL_CHANNELS)))
    for ts, vs in chunks:
        n = len(ts)
        t_buf[:n], v_buf[:n] = ts, vs
        got += svc.push("wheels", t_buf[:n], v_buf[:n])
        t_buf[:], v_buf[:] = 7.0, 0.5
    assert fresh.clock_restarts and _rows(got) == expected
    assert svc.refused_samples == fresh.refused_samples


def test_a_decision_owns_its_probabilities(wheel_model, wheels):
    chunks = _chunks(wheels, 5)
    expected = _rows(_push_all(_service(wheel_model), chunks))
    svc, got = _service(wheel_model), []
    for t, v in chunks:
        out = svc.push("wheels", t, v)
        got += _rows(out)
        for d in out:
            d.proba[:] = 0.0   # a caller writing into a decision's array
    assert got == expected


def test_two_services_used_interleaved_decide_as_used_one_after_the_other(wheel_model,
                                                                          wheels):
    a_chunks = _chunks(wheels, 3)
    b_chunks = _chunks(wheels.iloc[40:].reset_index(drop=True), 11)
    a_alone = _rows(_push_all(_service(wheel_model), a_chunks))
    b_alone = _rows(_push_all(_service(wheel_model), b_chunks))
    a, b, got_a, got_b = _service(wheel_model), _service(wheel_model), [], []
    for i in range(max(len(a_chunks), len(b_chunks))):
        if i < len(b_chunks):
            got_b += b.push("wheels", *b_chunks[i])
        if i < len(a_chunks):
            got_a += a.push("wheels", *a_chunks[i])
    assert _rows(got_a) == a_alone and _rows(got_b) == b_alone


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_a_copied_service_decides_as_the_original_and_apart_from_it(wheel_model, wheels, how):
    chunks = _chunks(wheels, 9)
    half = len(chunks) // 2
    svc = _service(wheel_model)
    _push_all(svc, chunks[:half])
    twin = copy.deepcopy(svc) if how == "deepcopy" else pickle.loads(pickle.dumps(svc))
    rest = _rows(_push_all(twin, chunks[half:]))
    assert rest and _rows(_push_all(svc, chunks[half:])) == rest
    assert twin.refused_samples == svc.refused_samples


def test_a_service_on_the_table_targets_copies(wheel_model, wheels):
    chunks = _chunks(wheels, 9)
    svc = StreamService(wheel_model, TableTargets(wheel_model.classes), StreamConfig())
    _push_all(svc, chunks[:5])
    twin = pickle.loads(pickle.dumps(copy.deepcopy(svc)))
    assert _rows(_push_all(twin, chunks[5:])) == _rows(_push_all(svc, chunks[5:]))


@pytest.mark.parametrize("metadata", [None, {"vehicle": "husky"},
                                      MappingProxyType({"vehicle": "husky"})])
def test_a_copied_model_keeps_its_metadata_as_read_only_as_it_was(wheel_model, metadata):
    model = wheel_model if metadata is None else replace(wheel_model, metadata=metadata)
    for twin in (copy.copy(model), copy.deepcopy(model), pickle.loads(pickle.dumps(model))):
        assert type(twin.metadata) is type(model.metadata)
        assert dict(twin.metadata) == dict(model.metadata)
        assert (twin.channels, twin.window, twin.classes) == (
            model.channels, model.window, model.classes)


def test_stream_config_copies_and_pickles():
    config = StreamConfig(clock_offsets_s={"wheels": 0.25}, hop_s=0.3)
    for twin in (copy.copy(config), copy.deepcopy(config),
                 pickle.loads(pickle.dumps(config))):
        assert twin == config
        assert dict(twin.streams) == dict(config.streams)
        assert dict(twin.clock_offsets_s) == {"wheels": 0.25}


def test_stream_config_does_not_follow_the_callers_dicts_after_it_is_checked():
    streams = {"imu": ["wz", "ax"], "wheels": ["vel_l", "vel_r"]}
    offsets = {"wheels": 0.5}
    config = StreamConfig(streams=streams, clock_offsets_s=offsets)
    streams["wheels"].append("wz")      # would name wz twice: refused at construction
    streams["gps"] = ("lat",)
    offsets["wheels"] = float("nan")    # refused at construction
    assert dict(config.clock_offsets_s) == {"wheels": 0.5}
    assert {s: tuple(c) for s, c in config.streams.items()} == {
        "imu": ("wz", "ax"), "wheels": ("vel_l", "vel_r")}


@settings(max_examples=30, deadline=None)
@given(st.lists(st.one_of(st.none(), st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3)),
                min_size=1, max_size=12),
       st.sampled_from([None, 2.0, 10.0]), st.integers(0, 11))
def test_a_copied_filter_updates_as_the_original(qs, dwell_s, cut):
    config = SmoothingConfig(dwell_s=dwell_s)
    f = ForwardFilter(3, 0.5, config)
    qs = [None if q is None else np.array(q) for q in qs]
    for q in qs[:cut]:
        f.update(q)
    twins = [copy.deepcopy(f), pickle.loads(pickle.dumps(f))]
    for q in qs[cut:]:
        d, p = f.update(q)
        p[:] = -1.0   # the returned array is the caller's
        for twin in twins:
            d2, p2 = twin.update(q)
            assert d2 == d
            np.testing.assert_array_equal(p2, f.p)


def test_replay_leaves_the_run_as_it_was(wheel_model, borealtc_runs, train_runs):
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.run_id not in seen)
    before = {s: f.copy() for s, f in run.streams.items()}
    meta = copy.deepcopy(dict(run.meta))
    replay_run(_service(wheel_model), run, max_chunk=16)
    for s, f in run.streams.items():
        pd.testing.assert_frame_equal(f, before[s])
    assert dict(run.meta).keys() == meta.keys()


def test_a_request_is_left_as_sent_and_answered_whatever_came_before(served_wheels,
                                                                     unseen_wheel_request):
    first, second = unseen_wheel_request(8.0), unseen_wheel_request(12.0)
    second.index = second.index + 1000     # a request with its own index
    alone = served_wheels.decide(second.copy())
    settings = copy.deepcopy(served_wheels.settings)
    bad = second.copy()
    bad.loc[bad.index[5], "t_s"] = np.nan
    for frame in (first, bad.iloc[:3], bad):
        sent = frame.copy()
        state = np.random.get_state()
        try:
            served_wheels.decide(frame)
        except TerrainError:
            pass
        pd.testing.assert_frame_equal(frame, sent)
        assert np.array_equal(np.random.get_state()[1], state[1])
    sent = second.copy()
    pd.testing.assert_frame_equal(served_wheels.decide(second), alone)
    pd.testing.assert_frame_equal(second, sent)
    assert served_wheels.settings == settings


class _FailingOnce(CataloguePeakTargets):
    """Catalogue targets whose ``fail_at``-th answer raises (a provider briefly down)."""

    def __init__(self, classes, fail_at):
        super().__init__(classes)
        self.fail_at, self.calls = fail_at, 0

    def target_for(self, terrain, confidence, stale):
        self.calls += 1
        if self.calls == self.fail_at:
            raise RuntimeError("provider down")
        return super().target_for(terrain, confidence, stale)


@pytest.mark.parametrize("fail_at", [1, 4, 9])
def test_a_decision_that_raised_is_made_again_on_the_filter_as_before_it(
        wheel_model, wheels, fail_at):
    chunks = _chunks(wheels, 1)
    expected = _rows(_push_all(_service(wheel_model), chunks))
    svc = StreamService(wheel_model, _FailingOnce(wheel_model.classes, fail_at),
                        StreamConfig())
    got, raised = [], 0
    for t, v in chunks:
        try:
            got += svc.push("wheels", t, v)
        except RuntimeError:
            raised += 1
    assert raised == 1 and len(expected) > fail_at
    assert _rows(got) == expected


def test_held_samples_are_copies_of_the_pushed_arrays():
    t, v = np.array([10.0, 10.1, 10.2]), np.arange(6.0).reshape(3, 2)
    run, chunks = HeldRun(8), HeldChunks()
    run.extend_clock(t, v, 1.0, {})
    run.append(10.3, v[2])
    chunks.append(t, v)
    t[:], v[:] = -1.0, -1.0     # the robot refills its arrays
    held_t, held_v = run.arrays()
    np.testing.assert_array_equal(held_t, [10.0, 10.1, 10.2, 10.3])
    np.testing.assert_array_equal(held_v, [[0, 1], [2, 3], [4, 5], [4, 5]])
    (chunk_t, chunk_v), = chunks.take()
    np.testing.assert_array_equal(chunk_t, [10.0, 10.1, 10.2])
    np.testing.assert_array_equal(chunk_v, np.arange(6.0).reshape(3, 2))
