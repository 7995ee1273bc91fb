"""Review sim20: the parameter dataclasses of the simulator's force model
(terrain/sim/forces.py) refuse impossible values with a ConfigError naming ``Class.field``."""

from __future__ import annotations

import math
from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError
from terrain.sim.forces import COMBINED_SLIP, LOAD_TRANSFER, CombinedSlipParams, \
    LoadTransferParams

_NOT_A_LENGTH = (True, False, math.nan, math.inf, -math.inf, -0.2, np.float64("nan"), "0.2",
                 None)


@pytest.mark.parametrize("bad", _NOT_A_LENGTH)
def test_a_cog_height_that_is_not_a_finite_height_is_refused(bad):
    # NaN gave NaN normal loads (and NaN forces) on every step of a v2 run, a negative height
    # loaded the inner wheels of a turn, True a 1 m high centre of gravity
    with pytest.raises(ConfigError, match=r"LoadTransferParams\.cog_height_m"):
        LoadTransferParams(bad, "test")


@settings(max_examples=30, deadline=None)
@given(st.floats(0.0, 2.0))
def test_a_finite_cog_height_is_kept(h):
    assert LoadTransferParams(h, "test").cog_height_m == h


def test_the_shipped_load_transfer_and_tyre_entries_are_valid():
    for entry in LOAD_TRANSFER.values():
        assert replace(entry) == entry
    for tyre in COMBINED_SLIP.values():
        assert replace(tyre) == tyre


@pytest.mark.parametrize("bad", (True, math.nan, math.inf, 0.0, -0.6, 1.5, "0.6", None))
def test_a_side_force_factor_outside_0_1_is_refused(bad):
    # documented in (0, 1]: NaN gave NaN side forces, 1.5 a tyre gripping sideways more than
    # its friction, a negative factor a side force along the slide
    with pytest.raises(ConfigError, match=r"CombinedSlipParams\.side_force_factor"):
        CombinedSlipParams(bad, "test")


@pytest.mark.parametrize("bad", (1, 0, "yes", None, np.float64(1.0)))
def test_hold_at_peak_must_be_a_boolean(bad):
    with pytest.raises(ConfigError, match=r"CombinedSlipParams\.hold_at_peak"):
        CombinedSlipParams(0.6, "test", hold_at_peak=bad)


@pytest.mark.parametrize("bad", (True, math.nan, math.inf, 0.0, -5.0, "5", None))
def test_a_friction_scale_that_is_not_a_finite_factor_above_0_is_refused(bad):
    # a NaN or infinite factor passed surface_curve's 'factor > 0' (inf: an infinite
    # friction, refused later by BurckhardtCurve without naming the tyre), True scaled by 1
    with pytest.raises(ConfigError, match=r"CombinedSlipParams\.friction_scale\[ICE\]"):
        CombinedSlipParams(0.6, "test", friction_scale=MappingProxyType({"ICE": bad}))


@pytest.mark.parametrize("bad", (5.0, [("ICE", 5.0)], None))
def test_friction_scale_must_be_a_mapping_of_terrain_names(bad):
    with pytest.raises(ConfigError, match=r"CombinedSlipParams\.friction_scale"):
        CombinedSlipParams(0.6, "test", friction_scale=bad)
    with pytest.raises(ConfigError, match=r"CombinedSlipParams\.friction_scale"):
        CombinedSlipParams(0.6, "test", friction_scale={3: 5.0})


@settings(max_examples=30, deadline=None)
@given(st.floats(1e-6, 1.0), st.booleans(), st.floats(1e-3, 10.0))
def test_a_tyre_in_range_is_kept(k_s, hold, factor):
    tyre = CombinedSlipParams(k_s, "test", hold_at_peak=hold,
                              friction_scale=MappingProxyType({"ICE": factor}))
    assert (tyre.side_force_factor, tyre.hold_at_peak, tyre.friction_scale["ICE"]) == (
        k_s, hold, factor)


@pytest.mark.parametrize("bad", ("no", "False", 1, 0, None, np.float64(1.0)))
def test_make_commands_omnidirectional_must_be_a_boolean(bad):
    # 'no' was truthy: the random scenario drew lateral commands for a skid-steer, which
    # integrate then refused with a message about v_y instead of the flag
    from terrain.sim.scenarios import make_commands
    with pytest.raises(ConfigError, match=r"make_commands\.omnidirectional"):
        make_commands("random", 10.0, 0.01, np.random.default_rng(0), 1.0, omnidirectional=bad)


@pytest.mark.parametrize("flag", (True, False, np.bool_(True)))
def test_make_commands_takes_true_false_and_numpy_booleans(flag):
    from terrain.sim.scenarios import make_commands
    cmd = make_commands("random", 10.0, 0.01, np.random.default_rng(0), 1.0,
                        omnidirectional=flag)
    assert bool(np.any(cmd.twist[:, 1] != 0.0)) == bool(flag)
