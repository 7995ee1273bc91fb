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
