"""``write_run`` replaces a ``vehicle`` of the run's meta by the run's own vehicle (by which
the readers read the run back); a different one is warned (rule ``meta_keys``, as
``read_run`` warns a key it replaces), where it was dropped without a word."""

import re
import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError, DataWarning
from terrain.io.measured import read_runs_dir
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _run(meta: dict, vehicle: str = "husky", az: float = 9.81) -> Run:
    rng = np.random.default_rng(0)
    imu = pd.DataFrame({TIME: np.arange(300) / 100.0,
                        **{c: rng.normal(0.0, 0.1, 300) for c in IMU_CHANNELS}})
    imu["az"] += az
    wheels = pd.DataFrame({TIME: np.arange(40) / 6.5,
                           **{c: rng.uniform(0.0, 0.5, 40) for c in WHEEL_CHANNELS}})
    return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
               streams={"imu": imu, "wheels": wheels}, vehicle=vehicle, meta=meta)


@pytest.mark.parametrize("value", ["tracked", "agrimaro", None, 3, ["husky"]])
def test_a_meta_vehicle_other_than_the_runs_is_warned_naming_file_run_and_values(
        tmp_path, value):
    with pytest.warns(DataWarning) as caught:
        paths = write_run(_run({"vehicle": value, "note": "kept"}), tmp_path, 0)
    said = [str(w.message) for w in caught if issubclass(w.category, DataWarning)]
    assert len(said) == 1
    assert re.fullmatch(re.escape(f"{paths['meta']}: rule meta_keys: key 'vehicle' of the "
                                  f"metadata of run x/ASPHALT/00 is {value!r}, the run's "
                                  "vehicle 'husky'") + ".*not kept", said[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = read_runs_dir(tmp_path)[0]
    assert back.vehicle == "husky" and back.meta["vehicle"] == "husky"
    assert back.meta["note"] == "kept"


@pytest.mark.parametrize("meta", [{}, {"vehicle": "husky"}, {"vehicle": "HUSKY"}])
def test_a_meta_vehicle_that_names_the_runs_is_written_without_a_word(tmp_path, meta):
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        write_run(_run(meta), tmp_path, 0)


def test_a_refused_run_warns_nothing(tmp_path):
    # (an accelerometer in g: the readers refuse it, so nothing is written nor warned)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        with pytest.raises(ConfigError):
            write_run(_run({"vehicle": "tracked"}, az=1.0), tmp_path, 0)
    assert not any(tmp_path.rglob("*.json"))
