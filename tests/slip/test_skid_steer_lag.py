"""The estimated wheel-stream lag moves the rim speeds back onto the filter's time."""

from __future__ import annotations

import numpy as np
import pytest

from pipelines.validation.harness import simulate_husky, truth_on_grid
from terrain.sim import Effects, SimConfig, simulate_with_physics
from terrain.slip import estimate_run


@pytest.mark.slow
def test_skid_steer_slip_with_the_lag_applied_beats_no_lag():
    # wheels planted 0.4 s late: the slip must take the wheel sample of t + lag (moving the
    # wheel times the other way doubles the misalignment); RMS 0.105 against 0.169
    base = simulate_husky("ASPHALT", seed=2, duration_s=30.0, icr_expansion=1.0)
    lagged = simulate_with_physics(SimConfig(**{**base.config.__dict__,
                                                "effects": Effects(wheel_lag=0.4)}))
    errs = {}
    for mode in ("none", "xcorr"):
        est = estimate_run(lagged.run, lag=mode)
        tr = truth_on_grid(lagged, est.ekf.t_s)
        moving = (np.abs(tr["v_bx"]) > 0.1).to_numpy() & (est.ekf.t_s > 5)
        e = est.slip[moving] - tr[["slip_1", "slip_2"]].to_numpy()[moving]
        errs[mode] = float(np.sqrt(np.nanmean(e ** 2)))
    assert errs["xcorr"] < 0.8 * errs["none"], errs


def test_resample_gives_nan_for_a_column_with_a_single_finite_sample():
    from terrain.slip.estimate import resample
    t = np.array([0.0, 1.0, 2.0])
    values = np.array([[1.0, np.nan], [2.0, 5.0], [3.0, np.nan]])
    out = resample(np.array([0.5, 1.0, 2.5]), t, values)
    np.testing.assert_allclose(out[:, 0], [1.5, 2.0, np.nan])
    assert np.isnan(out[:, 1]).all()             # one sample: no line to interpolate on


def test_resample_names_sample_times_out_of_order():
    # np.interp read unsorted or NaN times silently: [0, 2, 1] gave NaN at 1.5 s (1.5 in
    # time order), one NaN time made the whole column NaN
    import pytest

    from terrain.errors import TimeStepError
    from terrain.slip.estimate import resample
    values = np.array([[0.0], [2.0], [1.0]])
    for t, row in ((np.array([0.0, 2.0, 1.0]), 2), (np.array([0.0, np.nan, 2.0]), 1)):
        with pytest.raises(TimeStepError, match=f"resample: t_s .*sample {row} "):
            resample(np.array([0.5, 1.5]), t, values)


def test_resample_names_values_of_another_shape():
    # 1-D values raised a bare IndexError (tuple index out of range)
    import pytest

    from terrain.errors import ShapeError
    from terrain.slip.estimate import resample
    t = np.array([0.0, 1.0, 2.0])
    for values in (np.array([0.0, 1.0, 2.0]), np.zeros((2, 1))):
        with pytest.raises(ShapeError, match="resample: values"):
            resample(np.array([0.5, 1.5]), t, values)
