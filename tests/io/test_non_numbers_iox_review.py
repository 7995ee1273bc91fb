"""The one rule of values that must be numbers (:func:`terrain.errors.first_non_number_cell`),
shared by a data column's cells (:func:`terrain.io.align.first_non_number`: readers' clock,
alignment, writer) and the kinematics' array arguments
(:func:`terrain.vehicles.common.float_arrays`); they differ on a missing cell only."""

import datetime
import decimal
import fractions

import numpy as np
import pandas as pd
import pytest

from terrain.errors import EstimationError, first_non_number_cell, missing_cell, real_number
from terrain.io.align import first_non_number
from terrain.vehicles.common import float_arrays

#: cells that are real numbers (NaN and inf too: their own rules judge them)
NUMBERS = {"float": 2.5, "int": 3, "nan": float("nan"), "inf": float("inf"),
           "np.float32": np.float32(2.5), "np.int64": np.int64(3),
           "np.float32 nan": np.float32("nan"), "Fraction": fractions.Fraction(1, 2)}
#: cells that are missing: a sample for a data column, no value for an argument
MISSING = {"None": None, "pd.NA": pd.NA, "pd.NaT": pd.NaT}
#: cells that are not numbers, whatever NumPy or float() make of them
NOT_NUMBERS = {"True": True, "np.True_": np.True_, "False": False, "b'1'": b"1",
               "np.bytes_": np.bytes_(b"1"), "'nan'": "nan", "'1e3'": "1e3",
               "np.str_": np.str_("1"), "1j": 1j, "np.complex128": np.complex128(1 + 2j),
               "np.timedelta64": np.timedelta64(5, "s"),
               "np.datetime64": np.datetime64("2020-01-01"),
               "Decimal": decimal.Decimal("1.5"), "datetime": datetime.datetime(2020, 1, 1),
               "pd.Timestamp": pd.Timestamp("2020"), "pd.Timedelta": pd.Timedelta(1, "s"),
               "list": [1]}


def _column(cell) -> pd.Series:
    return pd.Series([1.0, cell, 2.0], dtype=object)


def _argument_refused(cell) -> bool:
    try:
        float_arrays("f", x=[1.0, cell, 2.0])
    except EstimationError as exc:
        assert str(exc).startswith("f: x must hold numbers")
        return True
    return False


@pytest.mark.parametrize("cell", NUMBERS.values(), ids=NUMBERS)
def test_a_real_number_passes_both_callers(cell):
    assert real_number(cell) and not missing_cell(cell)
    assert first_non_number(_column(cell)) is None
    assert not _argument_refused(cell)


@pytest.mark.parametrize("cell", NOT_NUMBERS.values(), ids=NOT_NUMBERS)
def test_a_value_that_is_not_a_number_is_refused_by_both_callers_at_its_row(cell):
    # before: the kinematics read True as 1.0, np.complex128(1+2j) as 1.0 (a ComplexWarning),
    # a timedelta64 of 5 s as 5.0, a datetime64 as 18262.0 (days since 1970), a Decimal as
    # a float, where the data columns refused each of them
    assert first_non_number_cell([1.0, cell], allow_missing=True) == 1
    assert first_non_number_cell([1.0, cell], allow_missing=False) == 1
    assert first_non_number(_column(cell)) == 1
    assert _argument_refused(cell)


@pytest.mark.parametrize("cell", MISSING.values(), ids=MISSING)
def test_a_missing_cell_is_a_sample_of_a_column_but_no_argument(cell):
    assert missing_cell(cell) and not real_number(cell)
    assert first_non_number_cell([1.0, cell], allow_missing=True) is None
    assert first_non_number_cell([1.0, cell], allow_missing=False) == 1
    assert first_non_number(_column(cell)) is None
    assert _argument_refused(cell)


def test_the_first_offending_cell_is_named_after_missing_ones():
    cells = [1.0, None, 2.0, "x", True]
    assert first_non_number_cell(cells, allow_missing=True) == 3
    assert first_non_number_cell(cells, allow_missing=False) == 1
    assert first_non_number_cell(iter([1, 2.0, np.int8(3)]), allow_missing=False) is None
    assert first_non_number_cell([], allow_missing=False) is None
