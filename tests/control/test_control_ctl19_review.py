"""Review checks (ctl19) of the control layer: the targets a traction step reads from any
record with the three attributes, the feed-forward limit's inputs, and the confidence rule
of the desired-slip table."""

from __future__ import annotations

import types

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.control import grid
from terrain.control.closed_loop import TractionLoop
from terrain.control.desired_slip import (CONFIDENCE_ROUNDING, build_slip_table,
                                          classifier_classes, confidence_is_trusted,
                                          select_target)
from terrain.control.estimators import FusedSlipObserver, WheelImuObserver
from terrain.control.feedforward import feedforward_step
from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionState,
                                      traction_control_step)
from terrain.errors import ConfigError, DataFormatError, ShapeError
from terrain.serving.targets import CataloguePeakTargets

FAST = settings(max_examples=60, deadline=None)


def _step(targets, slip=0.1):
    """One two-sided step of one wheel driving forward (1 rad/s, r 1 m) while accelerating."""
    cfg = TractionControlConfig(one_sided=False)
    return traction_control_step(cfg, TractionState.zeros(1), targets, [1.0], [1.0], [0.9],
                                 [0.5], 1.0, 0.02, 0.0, [slip])[0]


# --- targets read from any record ---------------------------------------------------------

@pytest.mark.parametrize("traction, braking, steady, named", [
    (-0.1, -0.15, 0.0, "traction"),    # wrong sign: the limiter slows a wheel that grips
    (0.1, 0.15, 0.0, "braking"),
    (0.1, -0.15, -0.05, "steady"),
    (1.5, -0.15, 0.0, "traction"),     # beyond the SAE slip's range
    ("0.1", -0.15, 0.0, "traction"),   # text: Python's bare TypeError in math.isfinite
    (True, -0.15, 0.0, "traction"),    # a boolean: read as a target of 1
    (0.1, -0.15, np.True_, "steady"),
    (None, -0.15, 0.0, "traction"),
])
def test_targets_of_a_plain_record_are_checked_as_slip_targets_are(traction, braking, steady,
                                                                   named):
    """A record with the three attributes (not a :class:`SlipTargets`, whose construction
    checks them) was read unchecked: a traction target of -0.1 made the step slow a wheel
    driving at a slip of 0.1 by 0.2 rad/s (error -0.2), ``True`` was a target of 1, text
    stopped on a bare TypeError. Now the :class:`SlipTargets` rule, named."""
    record = types.SimpleNamespace(traction=traction, braking=braking, steady=steady)
    with pytest.raises(ConfigError, match=rf"targets\.{named} must"):
        _step(record)


@FAST
@given(st.floats(0.01, 1.0), st.floats(-1.0, -0.01), st.floats(0.0, 1.0),
       st.floats(-1.0, 1.0))
def test_a_valid_plain_record_steps_as_the_same_slip_targets(traction, braking, steady, slip):
    """Valid targets in any record give the step of the same :class:`SlipTargets`."""
    record = types.SimpleNamespace(traction=traction, braking=braking, steady=steady)
    got, want = _step(record, slip), _step(SlipTargets(traction, braking, steady), slip)
    for a, b in zip(got, want):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_target_of_a_plain_record_still_gives_the_safe_output(bad):
    """Unchanged: a non-finite target is not known, so the step adds nothing."""
    for field in ("traction", "braking", "steady"):
        values = {"traction": 0.1, "braking": -0.15, "steady": 0.0, field: bad}
        out = _step(types.SimpleNamespace(**values))
        assert out.safe.all() and out.correction_rad_s[0] == 0.0


# --- the feed-forward limit's inputs ------------------------------------------------------

def _ff(**kw):
    """One feed-forward step of one wheel commanded at 1 rad/s from rest (r 0.2 m)."""
    args = dict(v_ref_m_s=np.zeros(1), v_est_m_s=np.zeros(1),
                omega_low_level_rad_s=np.ones(1), accel_limit_m_s2=1.0, target_slip=0.1,
                wheel_radius_m=0.2, dt_s=0.02)
    return feedforward_step(**{**args, **kw})


@pytest.mark.parametrize("radius", [np.inf, -np.inf, np.nan, 0.0])
def test_a_wheel_radius_that_is_not_finite_and_positive_is_refused(radius):
    """``wheel_radius_m=inf`` passed ``radius > 0``: the limit ``v_ref / (r (1 - s_t))``
    was 0 and the feed-forward stopped a wheel commanded at 1 rad/s (correction -1)."""
    with pytest.raises(ConfigError, match="wheel_radius_m"):
        _ff(wheel_radius_m=radius)


@pytest.mark.parametrize("name", ["v_ref_m_s", "v_est_m_s", "omega_low_level_rad_s"])
@pytest.mark.parametrize("bad", [["a"], ["1,5"], [[1.0, 2.0]]])
def test_an_input_that_is_not_real_numbers_is_a_data_format_error_naming_it(name, bad):
    """Text stopped on numpy's bare ValueError ('could not convert string to float'),
    naming no input; now the project's DataFormatError naming it."""
    with pytest.raises((DataFormatError, ShapeError), match=name):
        _ff(**{name: bad})


@pytest.mark.parametrize("engaged", [np.array([0.5]), ["no"], np.array([1])])
def test_engaged_that_is_not_booleans_is_refused(engaged):
    """``engaged`` is the previous step's boolean result; a float 0.5 or the text 'no' was
    read by truthiness as an engaged limit (the release then rate-limited)."""
    with pytest.raises(DataFormatError, match="engaged"):
        _ff(engaged=engaged)


@FAST
@given(st.floats(0.01, 2.0), st.floats(0.0, 0.9), st.floats(-5.0, 5.0), st.floats(0.0, 3.0),
       st.floats(0.0, 3.0), st.booleans())
def test_the_limit_never_raises_the_wheel_speed_nor_reverses_it(radius, slip, omega, v_ref,
                                                                v_est, engaged):
    """The correction only lowers ``|omega|`` (never beyond 0) and the reference stays a
    magnitude; a valid ``engaged`` of the previous step is taken as before."""
    ff = _ff(wheel_radius_m=radius, target_slip=slip, omega_low_level_rad_s=np.array([omega]),
             v_ref_m_s=np.array([v_ref]), v_est_m_s=np.array([v_est]),
             engaged=np.array([engaged]))
    cmd = omega + ff.correction_rad_s[0]
    assert abs(cmd) <= abs(omega) + 1e-12 and cmd * omega >= 0.0
    assert ff.v_ref_m_s[0] >= 0.0 and ff.engaged.dtype == bool


# --- the confidence rule --------------------------------------------------------------------

@pytest.mark.parametrize("confidence", [True, np.True_, "0.9", b"1", [0.9], 0.9 + 0j])
def test_a_confidence_that_is_not_a_real_number_is_a_config_error(confidence):
    """The one rule of a decision's confidence read ``True`` as a trusted probability of 1
    (the live service's catalogue-peak targets then used the class's targets) and stopped
    on Python's bare TypeError for text; now a ConfigError naming the confidence, in
    :func:`confidence_is_trusted` and in the provider that calls it."""
    with pytest.raises(ConfigError, match="confidence must be a real number"):
        confidence_is_trusted(confidence, 0.5)
    with pytest.raises(ConfigError, match="confidence must be a real number"):
        CataloguePeakTargets(["ICE", "TILES"]).target_for("ICE", confidence, False)


@FAST
@given(st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True),
                 st.integers(-3, 3)), st.floats(0.0, 1.0))
def test_the_confidence_rule_is_a_probability_at_or_above_the_threshold(confidence, threshold):
    """Real numbers and None are judged as before: trusted iff a finite probability (up to
    the rounding allowance above 1) at or above the threshold; NumPy scalars as floats."""
    want = (confidence is not None and np.isfinite(confidence)
            and threshold <= confidence <= 1.0 + CONFIDENCE_ROUNDING)
    assert confidence_is_trusted(confidence, threshold) == want
    if confidence is not None:
        assert confidence_is_trusted(np.float64(confidence), threshold) == want


# --- the skid-steer estimators' vehicle -----------------------------------------------------

@pytest.mark.parametrize("make", [WheelImuObserver, FusedSlipObserver])
def test_a_skid_steer_estimator_of_a_vehicle_without_a_track_is_a_config_error(make):
    """The fused observer of the AgriMaRo (three steered wheels, no track) stopped on a bare
    AttributeError ('AgriMaRoParams' object has no attribute 'track_m'); the wheel + IMU
    observer was built and failed so at its first wheel sample. Both now refuse it, named;
    the skid-steer vehicles are built as before."""
    with pytest.raises(ConfigError, match="agrimaro.*skid-steer"):
        make("agrimaro")
    for vehicle in ("husky", "tracked", "HUSKY"):
        assert make(vehicle).vehicle.track_m > 0


# --- a state holding a non-finite memory --------------------------------------------------

@FAST
@given(st.sampled_from(["integral", "slip_prev", "derivative", "correction"]),
       st.sampled_from([np.nan, np.inf, -np.inf]), st.floats(0.0, 20.0), st.booleans(),
       st.floats(-1.0, 1.0), st.floats(0.0, 2.0))
def test_a_non_finite_memory_gives_the_safe_output_of_that_unit_only(field, bad, ki, active,
                                                                     slip, chassis):
    """A state restored from a log or built by hand with a NaN in its memory gave a NaN
    wheel-speed command (integral NaN, or the held correction NaN while the chassis is too
    slow), and a NaN derivative stayed in the memory for good. Now that unit gets the safe
    output (no correction, memory cleared), as for a non-finite input; the other unit steps
    as from the same state without the bad entry."""
    cfg = TractionControlConfig(ki=ki, kd=0.1)
    targets = SlipTargets(0.1, -0.15, 0.0)
    clean = TractionState(np.full(2, 0.3), np.full(2, 0.05), np.ones(2, bool),
                          np.full(2, 0.2), np.full(2, -0.1), np.full(2, active))
    values = getattr(clean, field).copy()
    values[0] = bad
    state = clean._replace(**{field: values})
    args = (targets, [1.0, 1.0], [1.0, 1.0], [0.9, 0.9], [0.5, 0.5], chassis, 0.02, 0.0,
            [slip, slip])
    out, new = traction_control_step(cfg, state, *args)
    ref, _ = traction_control_step(cfg, clean, *args)
    assert np.all(np.isfinite(out.omega_cmd_rad_s))
    assert all(np.all(np.isfinite(np.asarray(f, dtype=float))) for f in new)
    if field != "slip_prev" or state.slip_valid[0]:
        assert out.safe[0] and out.omega_cmd_rad_s[0] == 1.0 and new.integral[0] == 0.0
    assert not out.safe[1] and out.omega_cmd_rad_s[1] == ref.omega_cmd_rad_s[1]


@pytest.mark.parametrize("state", [
    TractionState(*[a.tolist() for a in TractionState.zeros(2)]),   # read back from JSON
    None, (np.zeros(2),) * 6, {"integral": np.zeros(2)}])
def test_a_state_that_is_not_a_traction_state_of_arrays_is_a_config_error(state):
    """A state of lists (a log read back) or another record stopped on a bare
    AttributeError ('list' object has no attribute 'shape')."""
    with pytest.raises(ConfigError, match="state must be a TractionState of NumPy arrays"):
        traction_control_step(TractionControlConfig(), state, SlipTargets(0.1, -0.15, 0.0),
                              [1.0, 1.0], [1.0, 1.0], [0.9, 0.9], [0.5, 0.5], 1.0, 0.02)


# --- the classes of the desired-slip table ------------------------------------------------

def test_classes_given_as_an_iterator_build_the_same_table():
    """``build_slip_table`` read its classes twice (once to find the missing ones, once to
    build the entries): a generator of valid classes was used up by the first pass and the
    table said 'the desired-slip table has no entries'."""
    want = build_slip_table(["ICE", "TILES"]).frame()
    got = build_slip_table(c for c in ["ICE", "TILES"]).frame()
    assert got.equals(want)
    assert build_slip_table(iter(["ice"])).frame().equals(build_slip_table(["ICE"]).frame())


@pytest.mark.parametrize("make", [build_slip_table, classifier_classes])
@pytest.mark.parametrize("classes", [None, 5, 2.5])
def test_classes_that_are_not_a_sequence_are_a_config_error(make, classes):
    """None or a number stopped on Python's bare TypeError ('... is not iterable')."""
    with pytest.raises(ConfigError, match="needs a sequence of class names"):
        make(classes)


# --- the gain grids and the grid's gains, checked before any run ----------------------------

@pytest.mark.parametrize("kp_grid, ki_grid, named", [
    ([1.0, -1.0], [0.0], r"kp_grid\[1\]"), ([1.0], [0.0, np.nan], r"ki_grid\[1\]"),
    ([1.0, True], [0.0], r"kp_grid\[1\]"), ([1.0], ["0.5"], r"ki_grid\[0\]"),
    ([np.inf], [0.0], r"kp_grid\[0\]")])
def test_tune_gains_checks_its_gain_grids_before_any_run(monkeypatch, kp_grid, ki_grid, named):
    """A bad candidate gain was refused by the closed loop only when its turn came: after
    the uncontrolled baseline of every tuning terrain and seed and the controlled runs of
    the candidates before it (minutes of simulation), and without the grid's name."""
    runs = []
    monkeypatch.setattr(grid, "run_closed_loop", lambda *a, **k: runs.append(a))
    with pytest.raises(ConfigError, match=named):
        grid.tune_gains("husky", ["ICE"], kp_grid, ki_grid)
    assert runs == []


@pytest.mark.parametrize("gains, named", [
    ({"husky": (1.0, 0.0), "agrimaro": (-1.0, 0.0)}, "agrimaro"),
    ({"husky": (1.0, 0.0), "agrimaro": (1.0,)}, "agrimaro"),
    ({"husky": (1.0, 0.0), "agrimaro": (1.0, "a")}, "agrimaro"),
    ({"husky": (True, 0.0), "agrimaro": (1.0, 0.0)}, "husky")])
def test_run_grid_checks_every_vehicles_gains_before_any_run(monkeypatch, gains, named):
    """Bad gains of the second vehicle were refused only once its first run came, after
    every run of the first vehicle (hours on the full grid)."""
    runs = []
    monkeypatch.setattr(grid, "run_closed_loop", lambda *a, **k: runs.append(a))
    with pytest.raises(ConfigError, match=named):
        grid.run_grid(["husky", "agrimaro"], ["ICE"], ["straight_accel"], [0], gains)
    assert runs == []


# --- driving direction ----------------------------------------------------------------------

_cfgs = st.builds(TractionControlConfig, kp=st.floats(0.0, 5.0), ki=st.floats(0.0, 20.0),
                  kd=st.floats(0.0, 0.5), omega_max_rad_s=st.floats(1.0, 20.0),
                  output_fraction=st.floats(0.05, 1.0), one_sided=st.booleans())
_targets = st.builds(SlipTargets, traction=st.floats(0.01, 1.0), braking=st.floats(-1.0, -0.01),
                     steady=st.floats(0.0, 1.0))
#: (omega_low_level, omega_meas, v_long, a_local, chassis speed, dt) of one step
_steps = st.lists(st.tuples(st.floats(-25.0, 25.0), st.floats(-25.0, 25.0),
                            st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(0.0, 3.0),
                            st.floats(0.001, 0.1)), min_size=1, max_size=12)


@FAST
@given(_cfgs, _targets, _steps)
def test_reversing_mirrors_driving_forward(cfg, targets, seq):
    """Eqs. 8.7-8.9 take the target's sign from sgn(v_long) and the limits hold for either
    sign of the command: a run with every speed and acceleration negated (the same
    manoeuvre backwards) gives the negated commands and the same modes, step by step."""
    fwd = back = TractionState.zeros(1)
    for ll, w, v, a, chassis, dt in seq:
        o1, fwd = traction_control_step(cfg, fwd, targets, [ll], [w], [v], [a], chassis, dt)
        o2, back = traction_control_step(cfg, back, targets, [-ll], [-w], [-v], [-a],
                                         chassis, dt)
        np.testing.assert_allclose(o2.omega_cmd_rad_s, -o1.omega_cmd_rad_s, atol=1e-9)
        np.testing.assert_array_equal(o2.mode, o1.mode)
        np.testing.assert_array_equal(o2.enabled, o1.enabled)


# --- the table a decision is looked up in -------------------------------------------------

@pytest.mark.parametrize("table", [None, "ICE", "frame", "entries"])
def test_a_table_that_is_not_a_slip_table_is_a_config_error(table):
    """``select_target`` and :class:`TractionLoop` read ``table.config`` / ``table.entries``:
    the table's frame (``SlipTable.frame()``, what a robot engineer prints), its entries
    mapping or None stopped on a bare AttributeError ('DataFrame' object has no attribute
    'entries')."""
    good = build_slip_table(["ICE", "TILES"])
    table = {"frame": good.frame(), "entries": good.entries}.get(table, table)
    with pytest.raises(ConfigError, match="SlipTable"):
        select_target(table, "ICE")
    with pytest.raises(ConfigError, match="SlipTable"):
        TractionLoop(TractionControlConfig(), 2, WheelImuObserver(), table,
                     lambda t: ("ICE", 1.0))


# --- the grid's comparison ------------------------------------------------------------------

_RUN = dict(vehicle="husky", terrain="ICE", scenario="straight_accel", seed=3, peak_slip=0.5,
            energy_j_per_m=10.0, time_to_speed_s=2.0, slip_rmse=0.1,
            steady_slip_within_0_02=0.5, mean_speed_m_s=1.0, terrain_accuracy=1.0)


@pytest.mark.parametrize("rows, named", [
    ([dict(_RUN, controller="off")], "traction"),          # the uncontrolled runs alone
    ([dict(_RUN, controller="traction")], "off"),
    ([], "vehicle"),
    ([{k: v for k, v in dict(_RUN, controller=c).items() if k != "slip_rmse"}
      for c in ("off", "traction")], "slip_rmse")])
def test_compare_refuses_results_without_both_controllers_or_a_column(rows, named):
    """``compare`` of the uncontrolled runs alone (a filtered results table) stopped on
    pandas' bare KeyError ('peak_slip', 'traction'), an empty table or one without a metric
    on KeyError 'vehicle' / 'slip_rmse'; now a DataFormatError naming what is missing."""
    with pytest.raises(DataFormatError, match=named):
        grid.compare(pd.DataFrame(rows))


def test_compare_of_both_controllers_is_unchanged():
    table = grid.compare(pd.DataFrame([dict(_RUN, controller="off"),
                                       dict(_RUN, controller="traction", peak_slip=0.2)]))
    assert table.loc[0, "peak_slip_cut"] == pytest.approx(0.6) and table.loc[0, "runs"] == 1
