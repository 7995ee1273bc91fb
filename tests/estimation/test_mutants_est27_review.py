"""est27 mutation review: a test for each mutant of the EKF core that the suite let live."""

import numpy as np

from terrain.estimation.ekf import ExtendedKalmanFilter


def test_a_partial_update_shows_the_residual_h_of_x_at_the_rows_not_measured():
    # the residual sees full vectors; a row absent from z holds h(x) there (innovation 0), so
    # a residual coupling rows (here: innovations relative to their mean) is not fed an
    # invented measurement of 0 (mutant z_full = zeros survived the suite)
    seen = []

    def centred(z, hx):
        seen.append(z.copy())
        y = z - hx
        return y - y.mean()

    x0 = np.array([1.0, 2.0, 3.0])
    kf = ExtendedKalmanFilter(x0, np.eye(3), lambda x, dt: x, lambda x, dt: np.eye(3),
                              lambda x: x.copy(), lambda x: np.eye(3), np.zeros(3),
                              np.full(3, 0.1), residual=centred)
    inn = kf.update(np.array([1.6]), rows=[0])
    np.testing.assert_array_equal(seen[0], [1.6, 2.0, 3.0])
    np.testing.assert_allclose(inn.y, [0.6 - 0.2], atol=1e-15)
