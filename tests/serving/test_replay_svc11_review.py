"""Review svc11: what ``terrain stream`` tells a user of a replay (RunReplay.summary)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from terrain.run import Run
from terrain.serving.decisions import Decision, decisions_frame
from terrain.serving.replay import RunReplay


def _replay(refused: dict) -> RunReplay:
    run = Run("t/ASPHALT/00", "t", "ASPHALT",
              {"wheels": pd.DataFrame({"t_s": [0.0, 1.0], "vel_l": [0.1, 0.1]})})
    d = Decision(2.0, "ASPHALT", 0.9, np.array([0.9, 0.1]), 0.1, -0.1, 0.05, 0.0, "")
    frame = decisions_frame([d], ("ASPHALT", "GRASS"))
    return RunReplay(run, frame, 0, 10.0, 2.0, 0.5, 60.0, ("wheels",), refused, {}, 0)


def test_summary_counts_the_samples_the_service_refused():
    """The refused samples (counted per stream and reason by the service) reach the user
    of ``terrain stream``: a re-sent sample is refused without a flag, so the summary was
    the only place it could show; it said nothing of 7 duplicates and 3 non-finite
    samples."""
    text = _replay({("wheels", "duplicate"): 7, ("imu", "non_finite"): 3}).summary("d.csv")
    first = text.splitlines()[0]
    assert "refused 3 samples of stream imu (non_finite), 7 of stream wheels (duplicate)" \
        in first
    assert first.endswith("written to d.csv")
    # nothing refused: no word of it
    assert "refused" not in _replay({}).summary("d.csv")
