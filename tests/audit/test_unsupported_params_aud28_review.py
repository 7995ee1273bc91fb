"""Review aud28: an unsupported effect's parameter is fitted with the final model.

Mutation review of the simulation audit: the mutant that fitted an unsupported effect
alone (without the effects that joined the model) for its reported parameter and interval
passed the whole audit suite. Here the robot turns twice as slowly as its wheels command
(``chi = 2``, supported) and drifts slightly on straight stretches (commanded 0.04 rad/s,
quiet): the gyro has no bias, and the bias reported beside the selected ``chi`` must say
so; fitted against the bare replay (``x / 1.2``) instead, it reads
``0.04 / 2 - 0.04 / 1.2 = -0.0133`` rad/s.
"""

from __future__ import annotations

import pytest

from audit_helpers import synthetic_frame
from terrain.audit.selection import SelectionSettings, select_group


def test_the_bias_reported_beside_a_selected_chi_is_fitted_with_that_chi():
    units = [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=2.0, drift_rad_s=0.04)]
             for i in range(4)]
    g = select_group(units, "yaw", "ASPHALT",
                     SelectionSettings(n_bootstrap=50, n_param_bootstrap=10))
    assert g.selected == ("icr_expansion",)
    bias = {e.name: e for e in g.effects}["gyro_bias"]
    assert not bias.supported
    # no bias planted: only the gyro's white noise (0.005 rad/s) is left
    assert bias.params["bias_rad_s"] == pytest.approx(0.0, abs=1e-3)
    low, high = bias.ci95["bias_rad_s"]
    assert -1e-3 < low <= high < 1e-3
