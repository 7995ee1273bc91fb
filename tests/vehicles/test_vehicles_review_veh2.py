"""Review tests (hand mutants) of the vehicle parameter sets (veh2)."""

from __future__ import annotations

import pytest

from terrain.vehicles import AGRIMARO, HUSKY, TRACKED


def test_yaw_inertias_are_the_documented_plates():
    # Husky: m (L^2 + W^2) / 12 of the 0.99 x 0.67 m chassis; Patako: m (l^2 + B^2) / 12 over
    # the footprint (contact length l by tread B, not the 0.15 m track width); AgriMaRo:
    # m (w^2 + t^2) / 12 over the wheel triangle (w = 1.015 m, t = 0.756 m)
    assert HUSKY.yaw_inertia_kg_m2 == pytest.approx(50.0 * (0.99 ** 2 + 0.67 ** 2) / 12.0)
    assert TRACKED.yaw_inertia_kg_m2 == pytest.approx(
        TRACKED.mass_kg * (TRACKED.track_length_m ** 2 + TRACKED.track_m ** 2) / 12.0)
    assert TRACKED.yaw_inertia_kg_m2 == pytest.approx(1.0718, abs=1e-4)
    p = AGRIMARO.positions
    w, t = p[1, 0] - p[0, 0], -p[2, 1]
    assert (w, t) == pytest.approx((1.015, 0.756))
    assert AGRIMARO.yaw_inertia_kg_m2 == pytest.approx(AGRIMARO.mass_kg * (w * w + t * t) / 12.0)


def test_swerve_kinematics_use_the_geometry_given():
    # a variant with other wheel positions and radius: inverse then forward with the same
    # parameters returns the twist (every existing round trip used AGRIMARO itself)
    from dataclasses import replace

    import numpy as np

    from terrain.vehicles import swerve_forward, swerve_inverse
    variant = replace(AGRIMARO, wheel_radius_m=0.25,
                      wheel_positions_m=((-0.4, 0.1), (0.6, 0.0), (0.1, -0.9)))
    twists = np.array([[0.3, 0.8, -0.1], [-0.5, 0.2, 0.4], [0.0, -0.6, 0.0]])
    delta, omega = swerve_inverse(twists, variant)
    np.testing.assert_allclose(swerve_forward(delta, omega, variant), twists, atol=1e-12)
    # the same wheel commands on AGRIMARO would mean another motion
    assert not np.allclose(swerve_forward(delta, omega), twists, atol=1e-3)
