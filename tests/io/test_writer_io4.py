"""Review io4 of terrain.io.writer: the metadata file reads back as what the run held, in
standard JSON."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd

from terrain.io.measured import read_runs_dir
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _run(meta) -> Run:
    imu = pd.DataFrame({TIME: np.arange(200) / 100.0,
                        **{c: np.linspace(0.0, 1.0, 200) for c in IMU_CHANNELS}})
    imu["az"] += 9.81
    wheels = pd.DataFrame({TIME: np.arange(14) / 6.5,
                           **{c: np.linspace(0.1, 0.4, 14) for c in WHEEL_CHANNELS}})
    return Run("x/ASPHALT/00", "x", "ASPHALT", {"imu": imu, "wheels": wheels}, meta=meta)


def test_numpy_scalars_and_non_finite_values_of_meta_read_back_as_json_values(tmp_path):
    # json.dumps(default=str) wrote np.int64(3) as the text "3" and np.bool_(True) as
    # "True" (read back as strings), and NaN as the bare token NaN that strict JSON
    # readers (jq, JSON.parse) refuse; now 3, true and null (terrain.io.jsonfile's rule)
    meta = {"seed": np.int64(3), "noisy": np.bool_(True), "mu": np.float32(0.5),
            "lag_s": float("nan"), "nested": {"n": np.int32(7), "x": (1, 2.5)}}
    path = write_run(_run(meta), tmp_path, 0)["meta"]
    text = path.read_text()
    written = json.loads(text, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
    assert written["seed"] == 3 and isinstance(written["seed"], int)
    assert written["noisy"] is True
    assert written["mu"] == 0.5
    assert written["lag_s"] is None
    assert written["nested"] == {"n": 7, "x": [1, 2.5]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = read_runs_dir(tmp_path)[0]
    assert back.meta["seed"] == 3 and back.meta["noisy"] is True and back.meta["lag_s"] is None


def test_an_array_of_meta_is_written_as_a_json_list_in_full(tmp_path):
    # default=str wrote an array as its printed form, cut to "[   0    1    2 ... 1997 1998
    # 1999]" past 1000 values: read back as text, the values lost
    meta = {"wheel_radii_m": np.array([0.165, np.nan]), "ids": np.arange(2000)}
    text = write_run(_run(meta), tmp_path, 0)["meta"].read_text()
    written = json.loads(text)
    assert written["wheel_radii_m"] == [0.165, None]
    assert written["ids"] == list(range(2000))
