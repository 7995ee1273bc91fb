"""terrain.run.Run: metadata and streams of one drive."""

from __future__ import annotations

import pandas as pd

from terrain.run import Run


def test_a_run_without_samples_lasts_zero_seconds():
    # max() over no non-empty frame raised a bare "max() arg is an empty sequence"
    empty = pd.DataFrame({"t_s": [], "vel_l": []})
    assert Run("sim/X/00", "sim", None, {"wheels": empty}).duration_s == 0.0
    assert Run("sim/X/01", "sim", None, {}).duration_s == 0.0
    two = pd.DataFrame({"t_s": [1.0, 3.5]})
    assert Run("sim/X/02", "sim", None, {"wheels": two}).duration_s == 2.5
