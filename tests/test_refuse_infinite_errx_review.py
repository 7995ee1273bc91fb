"""The one infinite-value rule (:func:`terrain.errors.refuse_infinite`) takes any shape and
the argument's name: on a 1-D or 0-D array it failed with NumPy's bare ValueError ("not
enough values to unpack", "Calling nonzero on 0d arrays"), and it called every argument "X".
``grade_resistance_n`` now refuses an infinite pitch by it, with the message it had."""

import numpy as np
import pytest

from terrain.errors import NonFiniteInputError, refuse_infinite
from terrain.terramechanics.resistance import grade_resistance_n


@pytest.mark.parametrize("X, where", [
    (np.array([0.0, np.inf, -np.inf]), "2 infinite value(s), the first at flat index 1"),
    (np.array(-np.inf), "1 infinite value(s), the first at flat index 0"),
    (np.zeros((2, 2, 2)) + [0.0, np.inf], "4 infinite value(s), the first at flat index 1")])
def test_refuse_infinite_takes_any_shape_and_names_the_argument(X, where):
    with pytest.raises(NonFiniteInputError, match=r"^f: pitch holds " + where.replace(
            "(", r"\(").replace(")", r"\)") + "$"):
        refuse_infinite("f", X, name="pitch")


def test_refuse_infinite_keeps_its_feature_matrix_message_and_passes_nan():
    with pytest.raises(NonFiniteInputError, match=r"^f: X holds 1 infinite value\(s\), the "
                                                  r"first in column 'pitch', row 1 \(0-based\)"
                                                  r": why$"):
        refuse_infinite("f", np.array([[0.0, 1.0], [0.0, np.inf]]), ["wz", "pitch"], "why")
    with pytest.raises(NonFiniteInputError, match=r"the first at flat index 3$"):
        refuse_infinite("f", np.array([[0.0, 1.0], [0.0, np.inf]]), flat=True)
    refuse_infinite("f", np.array([np.nan, 1.0]))        # NaN: missing, not infinite
    refuse_infinite("f", np.array(np.nan))


def test_grade_resistance_names_an_infinite_pitch_by_the_shared_rule():
    with pytest.raises(NonFiniteInputError, match=r"^grade_resistance_n: pitch_rad holds 1 "
                                                  r"infinite value\(s\), the first at flat "
                                                  r"index 1$"):
        grade_resistance_n(50.0, np.array([[0.1, np.inf]]))
    assert np.isnan(grade_resistance_n(50.0, np.nan))
