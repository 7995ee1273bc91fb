"""Review tests (svc21) of the streaming service core: the model's training steps read
back, the ring buffer's usual step, the forward filter and the service's pushes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError
from terrain.serving import CataloguePeakTargets
from terrain.serving.model import model_channel_steps_s
from terrain.serving.targets import check_provider
from test_service_properties_svc17_review import (_chunked, _key, _push_chunks, _runs,
                                                  _service, _two_streams)


def test_a_channel_step_beyond_the_float_range_is_a_config_error_not_an_overflow():
    with pytest.raises(ConfigError, match="channel_steps_s"):
        model_channel_steps_s({"channel_steps_s": {"vel_l": 10 ** 400}})


def test_a_numpy_channel_step_is_read_as_the_number_it_is():
    steps = model_channel_steps_s({"channel_steps_s": {"vel_l": np.float32(0.125),
                                                       "ax": np.int64(1)}})
    assert steps == {"vel_l": 0.125, "ax": 1.0}
    with pytest.raises(ConfigError, match="channel_steps_s"):
        model_channel_steps_s({"channel_steps_s": {"vel_l": np.bool_(True)}})


def test_catalogue_targets_answer_a_class_in_any_case_as_the_provider_check_accepts_it():
    # check_provider compares the classes in upper case (as the tables look them up):
    # a provider built from 'snow' passed for a model deciding 'SNOW', which then got the
    # fallback (the slipperiest terrain's slip) on every trusted decision, unflagged
    targets = CataloguePeakTargets(["ice", "snow"])
    check_provider(targets, ("ICE", "SNOW"), 0.5)
    snow = targets.target_for("snow", 0.9, False)
    assert snow != targets.fallback
    assert targets.target_for("SNOW", 0.9, False) == snow
    assert targets.target_for("Snow", 0.9, True) == targets.fallback   # stale: fallback


def _two_stream_service():
    """The svc17 stand-in model (a softmax of the mean wheel speeds, 8 Hz) on two streams."""
    return _service()


def test_a_sample_without_a_stamp_is_flagged_where_one_by_one_flags_it_in_any_chunking():
    # a right sample with a NaN stamp inside a chunk was flagged at the stream's newest
    # stamp before the chunk (100.75 s, inside the window ending at 101.125 s), not at the
    # sample before it in the chunk (101.25 s), where pushed one by one it is: the window's
    # flags depended on the chunking
    tl = 100.0 + np.arange(1, 8) * 0.09375
    tr = 100.0 + np.arange(1, 20) * 0.125
    tr[9] = np.nan
    flags = []
    for chunks in ([[i] for i in range(6, 19)], [list(range(6, 18)), [18]]):
        svc, out = _two_stream_service(), []
        for i in range(6):
            out += svc.push("left", tl[i:i + 1], {"vel_l": [0.0]})
            out += svc.push("right", tr[i:i + 1], {"vel_r": [0.0]})
        out += svc.push("left", tl[6:], {"vel_l": [0.0]})
        for idx in chunks:
            out += svc.push("right", tr[idx], {"vel_r": np.zeros(len(idx))})
        assert svc.refused_samples == {("right", "non_finite"): 1}
        flags.append([(d.t_s, d.flags) for d in out])
    assert flags[0] == flags[1]
    assert flags[0][0] == (101.125, "short")


@pytest.mark.slow
@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data(), kinds=st.tuples(*[st.sampled_from(["value", "stamp", "range"])] * 2))
def test_two_faulty_streams_decide_and_flag_the_same_one_by_one_and_in_chunks(data, kinds):
    """The svc17 chunking property with samples refused for their values (NaN, out of the
    plausible range) or without a stamp (NaN) in either stream: the decisions, their flags
    and the counts do not depend on how the samples are chunked."""
    order, arrays = data.draw(_two_streams(min_size=5, max_size=50))
    # (a push refused whole for a NaN stamp says nothing of its stream's progress, by
    # design: the last sample of a run, pushed alone after a chunk, keeps its stamp)
    ends = {(s, idx[-1]) for s, idx in _runs(order)}
    for (name, (t, v)), kind in zip(arrays.items(), kinds):
        bad = np.array(data.draw(st.lists(st.booleans(), min_size=len(v), max_size=len(v))))
        bad &= np.arange(len(v)) % 3 == 0
        if kind == "value":
            v[bad] = np.nan
        elif kind == "range":
            v[bad] = 1e6
        else:
            t[bad & [(name, i) not in ends for i in range(len(t))]] = np.nan
    one, chunked = _service(), _service()
    a, _ = _push_chunks(one, arrays, [(s, [i]) for s, i in order])
    b, _ = _push_chunks(chunked, arrays, data.draw(_chunked(order)))
    assert _key(a) == _key(b)
    assert one.refused_samples == chunked.refused_samples
