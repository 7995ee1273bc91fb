"""Review of how a served request's numbers written as text are read (``numeric_column``).

A CSV body is text, and a CSV column holding one non-numeric cell reaches the model as a
column of text, so text holding a number (``"0.5"``, a JSON string too) is read as that
number, as the readers read a CSV cell; text that is no number is refused. A text number
beyond the float range is a value, not a missing sample: refused as the readers'
``_refuse_overflow`` refuses it, never read as inf and repaired.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ImplausibleValueError, NonNumericError
from terrain.serving.request import numeric_column


def test_text_holding_a_number_is_read_as_that_number():
    frame = pd.DataFrame({"cur_l": ["0.5", " 2 ", "-1e3", None]})
    np.testing.assert_array_equal(numeric_column(frame, "cur_l", np.arange(4), "request"),
                                  [0.5, 2.0, -1000.0, np.nan])


@pytest.mark.parametrize("word", ["inf", "-Infinity"])
def test_text_naming_an_infinite_sample_is_one_as_in_the_readers(word):
    frame = pd.DataFrame({"cur_l": ["0.5", word, "0.7"]})
    values = numeric_column(frame, "cur_l", np.arange(3), "request")
    assert values[0] == 0.5 and values[2] == 0.7 and not np.isfinite(values[1])


@pytest.mark.parametrize("text", ["1e400", "-1E+400", "9" * 400, "1" * 500 + ".5"])
def test_a_text_number_beyond_the_float_range_is_refused_not_read_as_inf(text):
    # before: read as +-inf, a non-finite sample the service repairs (answered 200)
    cells = ["0.5"] * 10
    cells[8] = text
    frame = pd.DataFrame({"cur_l": cells})
    with pytest.raises(ImplausibleValueError, match="beyond the float range") as err:
        numeric_column(frame, "cur_l", np.array([3, 5, 8, 9]), "request")
    assert err.value.column == "cur_l" and err.value.row == 8


def test_text_that_is_no_number_is_refused_naming_its_row():
    frame = pd.DataFrame({"cur_l": ["0.5", "0.6", "abc"]})
    with pytest.raises(NonNumericError, match="'abc'") as err:
        numeric_column(frame, "cur_l", np.arange(3), "request")
    assert err.value.row == 2


@pytest.mark.parametrize("word", ["nan", "NaN", " -nan ", ""])
def test_text_naming_a_missing_sample_is_one_as_in_the_readers(word):
    # the readers' NON_FINITE_WORDS: before, "inf" was a non-finite sample but "nan" and an
    # empty text were refused as non-numeric values
    frame = pd.DataFrame({"cur_l": ["0.5", word, "0.7"]})
    values = numeric_column(frame, "cur_l", np.arange(3), "request")
    assert values[0] == 0.5 and values[2] == 0.7 and np.isnan(values[1])
