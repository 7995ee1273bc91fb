"""`terrain validate`'s Markdown tables and its validation tables (pipelines.validation)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from pipelines.validate import to_markdown


def test_markdown_tells_an_infinite_figure_from_a_missing_one():
    # every non-finite float was printed "nan": a ratio that ran to infinity (a zero
    # denominator) read as a figure that is missing
    table = pd.DataFrame({"case": ["a", "b", "c"], "ratio": [np.inf, -np.inf, np.nan],
                          "x": [1.234567, 0.5, 2.0]})
    assert to_markdown(table).splitlines() == [
        "| case | ratio | x |", "|---|---|---|", "| a | inf | 1.235 |", "| b | -inf | 0.5 |",
        "| c | nan | 2 |"]
