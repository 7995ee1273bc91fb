"""The writer formats each number once, for the file and for the readers' rules
(:func:`terrain.io.writer._formatted`): pandas formatted every float again in ``to_csv``,
which doubled the write time of a long run. The files are pandas' own, byte for byte."""

import warnings

import numpy as np
import pandas as pd
import pytest
from pandas.io.formats import format as pandas_format

from terrain.io.writer import _file_format, to_file_frames, write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _run(t0_s: float, dtype=float) -> Run:
    """A small Husky run whose clocks start at ``t0_s``, with an extra stream of integer,
    text, object-number and float32 columns."""
    rng = np.random.default_rng(1)
    imu = pd.DataFrame({TIME: t0_s + np.arange(300) / 100.0,
                        **{c: rng.normal(0.0, 0.1, 300).astype(dtype) for c in IMU_CHANNELS}})
    imu["az"] += 9.81
    t_w = t0_s + np.arange(40) / 6.5
    wheels = pd.DataFrame({TIME: t_w, **{c: rng.uniform(0.0, 0.5, 40).astype(dtype)
                                         for c in WHEEL_CHANNELS}})
    extra = pd.DataFrame({TIME: t_w, "count": np.arange(40), "label": ["a b"] * 40,
                          "number": pd.Series(list(rng.normal(size=40)), dtype=object),
                          "single": rng.normal(size=40).astype(np.float32)})
    return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
               streams={"imu": imu, "wheels": wheels, "extra": extra}, vehicle="husky")


@pytest.mark.parametrize("t0_s, dtype", [(0.0, float), (0.0, np.float32), (1234.5, float),
                                         (1.7e9, float), (1e6, float)])
def test_the_files_are_pandas_own_csv_of_the_frames(tmp_path, t0_s, dtype):
    # (1.7e9 and 1e6: clocks written in full, float_format None)
    run = _run(t0_s, dtype)
    paths = write_run(run, tmp_path, 0)
    for kind, frame in to_file_frames(run).items():
        expected = frame.to_csv(index=False, float_format=_file_format(frame))
        assert paths[kind].read_bytes() == expected.encode()


def test_pandas_formats_no_float_of_a_file_written_with_nine_digits(tmp_path, monkeypatch):
    calls = []
    original = pandas_format.FloatArrayFormatter.get_result_as_array

    def counted(self):
        calls.append(len(self.values))
        return original(self)

    monkeypatch.setattr(pandas_format.FloatArrayFormatter, "get_result_as_array", counted)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        write_run(_run(0.0), tmp_path, 0)
    assert calls == []     # before: one call per float block of every file
