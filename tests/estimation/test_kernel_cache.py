"""Numba's on-disk cache checks only the file of a cached function, not the files of the
functions it inlines (the vehicle kinematics of :mod:`terrain.vehicles`): every cached EKF
kernel must still equal its Python source, which runs the current vehicle code."""

import numpy as np
import pytest

from terrain.estimation.equations import agrimaro, skid_steer
from terrain.estimation.equations.evaluate import NO_INPUT

AGRI_P = agrimaro.AgriMaRoEquationParams(camera=True).as_array()
SKID_P = skid_steer.SkidSteerEquationParams().as_array()
STALE = ("compiled kernel differs from its Python source: a stale numba cache; delete it with "
         "find terrain -name '*.nbi' -delete -o -name '*.nbc' -delete")


def _states(n, rng, count=20):
    x = rng.normal(0.0, 0.5, (count, n))
    return [np.ascontiguousarray(r) for r in x]


@pytest.mark.parametrize("kernel, p, n", [(agrimaro.transition_into, AGRI_P, 12),
                                          (agrimaro.transition_into, AGRI_P, 14),
                                          (skid_steer.transition_into, SKID_P, 4)])
def test_cached_transition_kernels_equal_their_source(kernel, p, n):
    rng = np.random.default_rng(0)
    for x in _states(n, rng):
        out = [(np.empty(n), np.empty((n, n))) for _ in range(2)]
        kernel(x, NO_INPUT, 0.05, p, *out[0])
        kernel.py_func(x, NO_INPUT, 0.05, p, *out[1])
        for compiled, source in zip(*out):
            np.testing.assert_allclose(compiled, source, rtol=1e-12, atol=1e-14, err_msg=STALE)


@pytest.mark.parametrize("kernel, p, n, m", [(agrimaro.observation_into, AGRI_P, 12, 14),
                                             (agrimaro.slip_state_observation_into, AGRI_P, 14,
                                             14),
                                             (skid_steer.observation_into, SKID_P, 4, 3)])
def test_cached_observation_kernels_equal_their_source(kernel, p, n, m):
    rng = np.random.default_rng(1)
    for x in _states(n, rng):
        out = [(np.empty(m), np.empty((m, n))) for _ in range(2)]
        kernel(x, p, *out[0])
        kernel.py_func(x, p, *out[1])
        assert np.abs(out[0][0]).max() > 0.0          # rows really computed
        for compiled, source in zip(*out):
            np.testing.assert_allclose(compiled, source, rtol=1e-12, atol=1e-14, err_msg=STALE)
