"""Text channels that :func:`write_run` writes must read back as written, or be refused."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError
from terrain.io.measured import read_runs_dir
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _run(labels) -> Run:
    t = np.arange(200) / 100
    imu = pd.DataFrame({TIME: t, **{c: 0.01 * np.sin(t * (k + 1))
                                    for k, c in enumerate(IMU_CHANNELS)}})
    imu["az"] = 9.81 + 0.01 * np.sin(t)
    tw = np.arange(20) / 10
    wheels = pd.DataFrame({TIME: tw, **{c: 0.3 + 0.01 * np.sin(tw * (k + 1))
                                        for k, c in enumerate(WHEEL_CHANNELS)}})
    truth = pd.DataFrame({TIME: np.linspace(0, 1.9, len(labels)), "terrain": labels})
    return Run(run_id="g/SNOW/00", dataset="g", terrain="SNOW", vehicle="husky", source="",
               streams={"imu": imu, "wheels": wheels, "truth": truth}, meta={})


@pytest.mark.parametrize("labels, row", [
    (["a\nb", "c", "d"], 0),      # a line break: the reader's row is ragged
    (["1", "2", "x"], 0),         # numbers among text: a NonNumericError on read
    (["A", "nan", "B"], 1),       # a non-finite word: read as a missing number
    (["A", "", "B"], 1),          # an empty cell: the same
    ([" x", "y", "z"], 0),        # spaces around: read back stripped, 'x'
    (["A", None, "B"], 1),        # None: written as an empty cell
])
def test_a_text_channel_that_would_not_read_back_is_refused_before_writing(
        tmp_path, labels, row):
    # write_run wrote them all; the readers then refused the file (a RaggedRowError, a
    # NonNumericError naming 'x' or 'A') or read ' x' back as 'x'
    with pytest.raises(ConfigError) as info:
        write_run(_run(labels), tmp_path)
    assert "'terrain'" in str(info.value) and "truth" in str(info.value)
    assert f"row {row}" in str(info.value)
    assert not any(tmp_path.iterdir())                    # nothing written


@pytest.mark.parametrize("labels", [["SNOW", "ICE", "SNOW"], ["a,b", "c d", "MIXED"]])
def test_a_text_channel_of_labels_reads_back_as_written(tmp_path, labels):
    write_run(_run(labels), tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        (back,) = read_runs_dir(tmp_path)
    assert list(back.streams["truth"]["terrain"]) == labels


@pytest.mark.parametrize("dtype", [bool, "boolean"])
def test_a_boolean_channel_is_refused_before_writing(tmp_path, dtype):
    # to_csv wrote True/False, which the readers took as a text channel: a contact flag
    # came back as the strings 'True' and 'False'
    run = _run(["SNOW", "ICE", "SNOW"])
    run.streams["truth"]["contact"] = pd.Series([True, False, True], dtype=dtype)
    with pytest.raises(ConfigError) as info:
        write_run(run, tmp_path)
    assert "column 'contact' holds booleans" in str(info.value)
    assert "'truth'" in str(info.value) and "0/1" in str(info.value)
    assert not any(tmp_path.iterdir())
    run.streams["truth"]["contact"] = run.streams["truth"]["contact"].astype(int)
    write_run(run, tmp_path)
    back = read_runs_dir(tmp_path)[0].streams["truth"]["contact"]
    assert back.tolist() == [1, 0, 1]
