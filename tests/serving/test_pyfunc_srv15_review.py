"""The aligned-samples pyfunc refuses a run named by a list or a mapping with the project's
typed error (srv15 review)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig
from terrain.errors import DataFormatError
from terrain.serving.pyfunc import predict_windows


class _Classifier:
    classes_ = np.array(["A", "B"])

    def predict_proba(self, X):
        return np.tile([0.3, 0.7], (len(X), 1))


@pytest.mark.parametrize("name", [["r1"], {"run": "r1"}])
def test_a_run_named_by_a_list_or_a_mapping_is_a_typed_error_naming_its_row(name):
    # was Python's bare "TypeError: unhashable type: 'list'" (pandas' unique of the runs)
    samples = pd.DataFrame({"run": "r1", "t_s": np.arange(200) / 20.0, "vel_l": 0.5,
                            "vel_r": 0.5}).astype({"run": object})
    samples.at[7, "run"] = name
    with pytest.raises(DataFormatError, match="run name") as exc:
        predict_windows(_Classifier(), samples, ["vel_l", "vel_r"],
                        WindowConfig(window_s=2.0, rate_hz=20.0), ["A", "B"])
    assert exc.value.column == "run" and exc.value.row == 7
    assert type(name).__name__ in str(exc.value)


@pytest.mark.parametrize("error,row,value", [
    ("TimestampError", 25, 0.05),       # moved back in time
    ("NonFiniteError", 25, np.nan),
    ("TimestampError", 39, 1.6)])       # the run's last sample after a hole
def test_a_timestamp_error_names_the_row_of_the_request_not_of_its_run(error, row, value):
    # two runs interleaved in one request: the error named run r2's row 12 (its 13th
    # sample), which is the request's row 25; the request's row is what the sender can find
    t = np.arange(20) / 20.0
    samples = pd.DataFrame({"run": np.tile(["r1", "r2"], 20), "t_s": np.repeat(t, 2),
                            "vel_l": 0.5, "vel_r": 0.5})
    samples.loc[row, "t_s"] = value
    with pytest.raises(Exception) as exc:
        predict_windows(_Classifier(), samples, ["vel_l", "vel_r"],
                        WindowConfig(window_s=0.5, rate_hz=20.0), ["A", "B"])
    assert type(exc.value).__name__ == error
    assert exc.value.column == "t_s" and exc.value.row == row
    assert "r2" in str(exc.value)
