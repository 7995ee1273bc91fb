"""Review: a push the service takes in pieces (longer than half the buffer) is taken as the
same samples pushed piece by piece by the caller."""

from __future__ import annotations

import numpy as np

from terrain.serving import CataloguePeakTargets, SmoothingConfig, StreamConfig, StreamService


def _imu(t):
    return np.column_stack([0.1 * np.sin(t), 0.1 * np.cos(t), 9.81 + 0.1 * np.sin(2 * t),
                            0.01 * np.sin(3 * t), 0.01 * np.cos(3 * t), 0.01 * np.sin(5 * t)])


def _wheels(t):
    return np.column_stack([0.3 + 0.05 * np.sin(t), 0.3 + 0.05 * np.cos(t),
                            8.0 + np.cos(t), 8.0 + np.sin(t)])


def _replay(model, caller_splits):
    """IMU at 50 Hz and wheels at 10 Hz pushed every 0.1 s; the IMU's clock steps 1000 s
    ahead at 20 s and is held ahead while the wheels go on; at 24 s the IMU sends 5 s in one
    push of 250 samples, over half the 400-sample buffer."""
    svc = StreamService(model, CataloguePeakTargets(model.classes),
                        StreamConfig(smoothing=SmoothingConfig(dwell_s=None),
                                     buffer_samples=400))
    ti, tw = np.arange(2500) / 50.0, np.arange(500) / 10.0
    imu_clock = np.where(ti >= 20.0, ti + 1000.0, ti)
    out = []

    def push(stream, lo, hi):
        t, clock, values = (ti, imu_clock, _imu) if stream == "imu" else (tw, tw, _wheels)
        m = (t >= lo - 1e-9) & (t < hi - 1e-9)
        out.extend(svc.push(stream, clock[m], values(t[m])))

    for k in range(240):
        push("imu", k / 10, (k + 1) / 10)
        push("wheels", k / 10, (k + 1) / 10)
    if caller_splits:
        push("imu", 24.0, 28.0)          # 200 samples: half the buffer, one piece
        push("imu", 28.0, 29.0)
    else:
        push("imu", 24.0, 29.0)          # 250 samples: the service takes 200 then 50
    for k in range(240, 290):
        push("wheels", k / 10, (k + 1) / 10)
    for k in range(290, 500):
        push("imu", k / 10, (k + 1) / 10)
        push("wheels", k / 10, (k + 1) / 10)
    return svc, out


def test_pieces_of_one_push_after_a_clock_is_moved_come_with_its_new_offset(all_model):
    # the first piece puts the held run on the wheels' clock (offset -1000 s); the second
    # piece kept the offset of the push's start, was held again as a step ahead, then
    # refused as a stray stamp ahead: 50 samples counted time_ahead, flagged windows
    by_caller, expected = _replay(all_model, caller_splits=True)
    by_service, got = _replay(all_model, caller_splits=False)
    assert by_caller.refused_samples == {} and by_caller.clock_restarts == 1
    assert by_service.refused_samples == {}
    assert by_service.clock_offsets_s == by_caller.clock_offsets_s
    assert abs(by_service.clock_offsets_s["imu"] + 1000.0) < 0.1
    assert [(d.t_s, d.terrain, d.flags) for d in got] == \
        [(d.t_s, d.terrain, d.flags) for d in expected]
