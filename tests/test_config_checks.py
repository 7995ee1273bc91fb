"""terrain.errors: the checks of settings (positive, integer, number) and message helpers."""

from __future__ import annotations

import re

import numpy as np
import pytest

from terrain.errors import ConfigError, config_positive


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf"), -np.inf])
def test_a_value_that_is_not_finite_and_positive_is_named_with_its_owner(value):
    with pytest.raises(ConfigError, match=rf"^HuskyParams\.mass_kg must be a finite value > 0, "
                                          rf"got {value!r}"):
        config_positive("HuskyParams", track_m=0.57, mass_kg=value)


def test_zero_passes_where_allowed_and_text_is_not_a_number():
    config_positive("SoilParams", allow_zero=True, cohesion_pa=0.0, unit_weight_n_m3=np.float32(1))
    with pytest.raises(ConfigError, match=r"SoilParams\.cohesion_pa must be a finite value >= 0"):
        config_positive("SoilParams", allow_zero=True, cohesion_pa=-1.0)
    with pytest.raises(ConfigError, match=r"bekker_sinkage_m\.n must be a real number"):
        config_positive("bekker_sinkage_m", n="0.7")


def test_listed_shows_the_first_items_and_counts_the_others():
    from terrain.errors import listed
    assert listed(["a", "b"]) == "['a', 'b']"
    assert listed([f"c{i}" for i in range(7)], 3) == "['c0', 'c1', 'c2'] and 4 more"
    assert listed(["x" * 40], show=lambda s: s[:4]) == "['xxxx']"


def test_first_items_shows_the_first_lines_and_counts_the_others():
    from terrain.errors import first_items
    assert first_items([4]) == "line 4"
    assert first_items([4, 9, 12]) == "lines 4, 9, 12"
    assert first_items([4, 9, 12, 20, 21]) == "lines 4, 9, 12 and 2 more"
    assert first_items(["a.csv", "b.csv"], limit=1, word="file") == "files a.csv and 1 more"


def test_duplicated_names_each_repeated_item_once_sorted():
    from terrain.errors import duplicated
    assert duplicated(["t_s", "ax", "wz", "ax", "t_s", "ax"]) == ["ax", "t_s"]
    assert duplicated(["a", "b"]) == []


@pytest.mark.parametrize("value, ok", [(0, False), (1, True), (5, True), (6, False),
                                       (np.int64(3), True), (True, False), (2.0, False),
                                       ("3", False), (None, False)])
def test_config_integer_takes_integers_in_the_closed_range_only(value, ok):
    from terrain.errors import config_integer
    if ok:
        config_integer("buffer_samples", value, 1, 5)
    else:
        with pytest.raises(ConfigError, match=rf"^buffer_samples must be an integer in \[1, 5\], "
                                              rf"got {re.escape(repr(value))}$"):
            config_integer("buffer_samples", value, 1, 5)


def test_config_integer_without_an_upper_bound():
    from terrain.errors import config_integer
    config_integer("reset_windows", 10 ** 9, 0)
    with pytest.raises(ConfigError, match=r"^reset_windows must be an integer >= 0, got -1$"):
        config_integer("reset_windows", -1, 0)


@pytest.mark.parametrize("value", [True, "1.0", b"1", 1j, [1.0], np.array([1.0, 2.0]),
                                   np.bool_(True), np.str_("1"), None])
def test_config_numbers_refuses_what_is_not_one_real_number(value):
    from terrain.errors import config_numbers
    with pytest.raises(ConfigError, match=r"^StreamConfig\.hop_s must be a real number, got "):
        config_numbers("StreamConfig", hop_s=value)


def test_config_numbers_takes_real_scalars_and_optional_none():
    from terrain.errors import config_numbers
    config_numbers("StreamConfig", ("dwell_s",), hop_s=0.5, n=3, f=np.float32(1.5),
                   i=np.int16(2), zero_d=np.array(2.5), dwell_s=None)


def test_holds_booleans_is_the_one_test_of_a_boolean_where_numbers_are_meant():
    import pandas as pd

    from terrain.errors import holds_booleans

    for x in (True, np.bool_(False), np.array([True, False]), [True, False], (False,),
              [[True], [False]], pd.Series([True, False])):
        assert holds_booleans(x), x
    for x in (1, 1.0, np.float64(2.0), np.ones(3), [1, 0], [], "True", None,
              pd.Series([1.0]), [[1.0], [2.0, 3.0]]):   # the last one ragged
        assert not holds_booleans(x), x


def test_is_integer_is_the_one_rule_of_a_count_or_an_index():
    from terrain.errors import is_integer

    assert all(is_integer(v) for v in (0, -3, np.int64(2), np.uint8(1)))
    assert not any(is_integer(v) for v in (True, np.bool_(True), 2.0, 0.5, "1", None,
                                           np.timedelta64(1, "s")))


def test_refuse_booleans_names_the_first_boolean_argument_with_the_error_asked_for():
    from terrain.errors import EstimationError, ShapeError, refuse_booleans

    refuse_booleans(ShapeError, "f", a=np.ones(3), b=[1, 0], c=None)    # numbers pass
    with pytest.raises(ShapeError, match=r"^f: b must hold numbers, got booleans$"):
        refuse_booleans(ShapeError, "f", a=np.ones(3), b=np.ones(2, bool), c=True)
    with pytest.raises(EstimationError, match=r"^c must hold numbers, got booleans$"):
        refuse_booleans(EstimationError, a=1.0, c=True)


def test_holds_booleans_sees_pandas_nullable_boolean_masks():
    """A pandas ``boolean`` (nullable) mask is a boolean dtype too: ``np.asarray(mask,
    float)`` reads it as 1 and 0, as a NumPy mask."""
    import pandas as pd

    from terrain.errors import holds_booleans

    for x in (pd.Series([True, False], dtype="boolean"), pd.array([True, False]),
              pd.Series([True, None], dtype="boolean")):
        assert holds_booleans(x), x
    for x in (pd.Series([1, 0], dtype="Int64"), pd.Series([1.0], dtype="Float64")):
        assert not holds_booleans(x), x


@pytest.mark.parametrize("value, ok", [(0, True), (3, True), (3.0, True), (np.int64(7), True),
                                       (2.7, False), (-1, False), (True, False),
                                       (float("nan"), False), (float("inf"), False),
                                       ("3", False), (None, False)])
def test_config_seed_takes_whole_numbers_from_zero(value, ok):
    from terrain.errors import config_seed

    if ok:
        config_seed("SimConfig.seed", value)
    else:
        with pytest.raises(ConfigError, match=r"^SimConfig\.seed must be an integer >= 0, got "):
            config_seed("SimConfig.seed", value)


@pytest.mark.parametrize("value, ok", [(1.0, True), (0.5, True), (np.float32(1e-3), True),
                                       (0.0, False), (-0.1, False), (1.0001, False),
                                       (95, False), (float("nan"), False)])
def test_config_fraction_takes_the_half_open_unit_interval(value, ok):
    from terrain.errors import config_fraction

    if ok:
        config_fraction("traction_peak", share=value)
    else:
        with pytest.raises(ConfigError, match=r"^traction_peak: share must be in \(0, 1\]"):
            config_fraction("traction_peak", share=value)


@pytest.mark.parametrize("value, ok", [(0.0, True), (1.0, True), (0, True), (np.float32(0.5), True),
                                       (-1e-9, False), (1.0001, False), (95, False),
                                       (float("nan"), False), (float("inf"), False)])
def test_config_probability_takes_the_closed_unit_interval(value, ok):
    """0 and 1 are thresholds a user may mean (never / always the fallback); NaN is refused
    (a NaN threshold is never crossed), named as owner.field."""
    from terrain.errors import config_probability

    if ok:
        config_probability("StreamConfig", min_confidence=value)
    else:
        with pytest.raises(ConfigError,
                           match=r"^StreamConfig\.min_confidence must be in \[0, 1\], got "):
            config_probability("StreamConfig", min_confidence=value)
    with pytest.raises(ConfigError, match=r"StreamConfig\.min_confidence must be a real number"):
        config_probability("StreamConfig", min_confidence=True)


@pytest.mark.parametrize("value", [1, 0, "no", "False", None, np.array([True])])
def test_config_flags_refuse_what_is_not_true_or_false_by_name(value):
    from terrain.errors import config_flags

    config_flags("ModelConfig", scale=True, balance=np.bool_(False))
    with pytest.raises(ConfigError, match=r"^ModelConfig\.balance must be True or False"):
        config_flags("ModelConfig", scale=True, balance=value)


def test_a_data_format_error_names_what_it_knows_and_skips_an_empty_source():
    """An in-memory run's source is "": no "file " in the message; the file line is named
    when known, else the 0-based data row; a message without a place is left alone."""
    from terrain.errors import DataFormatError

    assert str(DataFormatError("bad", path="", column="t_s", line=3)) == \
        "bad (column 't_s', line 3)"
    assert str(DataFormatError("bad", path="a.csv", column="t_s", row=4, line=6)) == \
        "bad (file a.csv, column 't_s', line 6)"
    assert str(DataFormatError("bad", row=4)) == "bad (data row 4 (0-based))"
    assert str(DataFormatError("bad", path="")) == "bad"


@pytest.mark.parametrize("check", ["config_positive", "config_fraction", "config_integer",
                                   "config_seed"])
def test_a_numpy_duration_is_not_a_number(check):
    # np.timedelta64 is an integer type to NumPy (a subclass of np.signedinteger):
    # config_positive raised a bare UFuncTypeError comparing it with 0.0, and config_integer
    # and config_seed took np.timedelta64(5, "s") and np.timedelta64(5, "ms") alike as 5
    import terrain.errors

    call = {"config_positive": lambda f, v: f("SimConfig", dt_s=v),
            "config_fraction": lambda f, v: f("traction_peak", fraction=v),
            "config_integer": lambda f, v: f("n_epochs", v, 1),
            "config_seed": lambda f, v: f("seed", v)}[check]
    with pytest.raises(ConfigError, match="dt_s|fraction|n_epochs|seed"):
        call(getattr(terrain.errors, check), np.timedelta64(5, "s"))


def test_refuse_unreal_names_the_first_input_that_is_not_numbers():
    """The control steps' shared slow-path refusal (one rule for traction and feed-forward,
    which had a copy each)."""
    from terrain.errors import DataFormatError, refuse_unreal

    refuse_unreal("f", ("s",), a=1.0, b=[1, 2], s=None)      # all real: no error
    cases = [(dict(a=1.0, b="x"), "b"), (dict(a=[1, "x"], b=1.0), "a"),
             (dict(a=1j), "a"), (dict(a=None), "a"), (dict(a=[1, [2, 3]]), "a")]
    for inputs, name in cases:
        with pytest.raises(DataFormatError, match=f"^f: {name} must hold real numbers") as e:
            refuse_unreal("f", (), **inputs)
        assert e.value.column == name


def test_real_arrays_refuses_booleans_with_the_error_given_and_text_naming_the_input():
    """The feature calculators' one input rule (statistics, physics_features,
    window_ekf_channels, slip features): booleans refused with the caller's error, what does
    not convert to real numbers as a DataFormatError naming the input; numbers come back as
    float arrays in the order given."""
    from terrain.errors import DataFormatError, EstimationError, real_arrays
    a, b = real_arrays("f", x=[1, 2], y=np.array([[3]], dtype=np.int8))
    assert a.dtype == b.dtype == float and a.tolist() == [1.0, 2.0] and b.shape == (1, 1)
    with pytest.raises(DataFormatError, match=r"^f: y must hold numbers, got booleans$"):
        real_arrays("f", x=[1.0], y=[True])
    with pytest.raises(EstimationError, match=r"^f: x must hold numbers, got booleans$"):
        real_arrays("f", EstimationError, x=np.array([False]))
    with pytest.raises(DataFormatError, match="^f: y must hold real numbers") as err:
        real_arrays("f", x=[1.0], y=["a"])
    assert err.value.column == "y"
