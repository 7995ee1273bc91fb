"""Review srv19 of :func:`terrain.serving.evaluation.concatenated_streams`' ``streams``."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError
from terrain.run import Run
from terrain.serving.evaluation import concatenated_streams


def _run(i: int, terrain: str) -> Run:
    t = np.arange(0.0, 40.0, 0.1)
    return Run(f"syn/{terrain}/{i}", "syn", terrain,
               {"wheels": pd.DataFrame({"t_s": t, "vel_l": np.full(len(t), float(i))})})


RUNS = [_run(0, "A"), _run(1, "B")]


def test_a_stream_named_twice_is_refused_not_laid_in_twice():
    """Each piece was appended once per name: every sample twice, the stream's clock
    stepping back at each piece (1428 rows for 714 samples)."""
    with pytest.raises(ConfigError, match="'wheels'.*more than once"):
        concatenated_streams(RUNS, ["wheels", "wheels"], 0)


@pytest.mark.parametrize("streams, words", [([], "no stream"), ((), "no stream"),
                                            ("wheels", "text")])
def test_no_stream_or_a_bare_name_is_refused(streams, words):
    # [] failed in Python's max() ("arg is an empty sequence"); "wheels" was read as the
    # streams 'w', 'h', ... which no run holds ("needs runs of at least two terrains")
    with pytest.raises(ConfigError, match=words):
        concatenated_streams(RUNS, streams, 0)


def test_distinct_streams_make_the_stream_once():
    run, _ = concatenated_streams(RUNS, ["wheels"], 0)
    t = run.streams["wheels"]["t_s"].to_numpy()
    assert len(t) == 714 and (np.diff(t) > 0).all()
