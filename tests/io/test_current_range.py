"""Rule ``current_range``: motor currents beyond the vehicle's assumed bound are warned about."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataWarning
from terrain.io.measured import COLUMN_MAPS, read_runs_dir
from terrain.io.plausibility import VEHICLE_LIMITS, check_run
from terrain.run import TIME


def _wheels(peak_a: float, n: int = 200) -> pd.DataFrame:
    """A straight Husky wheel stream at 10 Hz whose left current peaks at ``peak_a``."""
    t = np.arange(n) * 0.1
    cur = 3.0 + 0.5 * np.sin(t)
    cur_l = cur.copy()
    cur_l[n // 2] = peak_a
    return pd.DataFrame({TIME: t, "vel_l": 0.5 + 0.01 * np.sin(3 * t),
                         "vel_r": 0.5 + 0.01 * np.cos(3 * t), "cur_l": cur_l, "cur_r": cur})


@pytest.mark.parametrize("peak_a, warned", [(80.0, False), (80.5, True), (-200.0, True),
                                            (32.6, False)])
def test_a_current_beyond_the_vehicles_bound_is_warned_with_its_column(peak_a, warned):
    # VEHICLE_LIMITS' 80 A (ten times the Husky's 8 A continuous rating) was documented as a
    # vehicle bound stricter than the 1000 A range but judged nowhere: 500 A passed silently
    assert VEHICLE_LIMITS["husky"].max_current_a == 80.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        checks = check_run("r/X/00", {"wheels": _wheels(peak_a)}, "husky",
                           {"wheels": "pro_00.csv"}, columns={"wheels": COLUMN_MAPS["pro"]})
    found = [w for w in checks["warnings"] if "rule current_range" in w]
    assert bool(found) == warned
    if warned:
        (msg,) = found
        assert msg.startswith("pro_00.csv: rule current_range: ")
        assert "column 'curL' (wheels.cur_l)" in msg and "80 A" in msg
        assert f"{peak_a:g} A" in msg and "t = 10 s" in msg and "\n" not in msg


def test_the_current_bound_applies_to_the_vehicles_it_is_known_for_only():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        checks = check_run("r/X/00", {"wheels": _wheels(500.0)}, "tracked",
                           {"wheels": "pro_00.csv"})
    assert checks["warnings"] == []


def test_a_husky_file_with_currents_beyond_80_a_is_read_and_warned(tmp_path):
    folder = tmp_path / "SNOW"
    folder.mkdir()
    frame = _wheels(250.0).rename(columns={TIME: "time", "vel_l": "velL", "vel_r": "velR",
                                           "cur_l": "curL", "cur_r": "curR"})
    frame.to_csv(folder / "pro_00.csv", index=False)
    with pytest.warns(DataWarning, match=r"pro_00.csv: rule current_range: .*column 'curL'"):
        (run,) = read_runs_dir(tmp_path)
    assert any("rule current_range" in w for w in run.meta["warnings"])
    assert run.streams["wheels"]["cur_l"].max() == 250.0     # nothing rescaled


@pytest.mark.parametrize("bad", [np.inf, -np.inf, np.nan])
def test_a_non_finite_current_is_no_current_beyond_the_bound(bad):
    # a non-finite sample is the non-finite rule's (a served window flags it non_finite, as
    # a NaN); an inf was also warned as a current beyond 80 A, on every served window
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        checks = check_run("r/X/00", {"wheels": _wheels(bad)}, "husky",
                           {"wheels": "pro_00.csv"})
    assert not [w for w in checks["warnings"] if "rule current_range" in w]
    frame = _wheels(120.0)
    frame.loc[5, "cur_l"] = bad          # beside a real 120 A peak: that one is named
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        checks = check_run("r/X/00", {"wheels": frame}, "husky", {"wheels": "pro_00.csv"})
    (msg,) = [w for w in checks["warnings"] if "rule current_range" in w]
    assert "1 sample(s)" in msg and "the largest 120 A at t = 10 s" in msg
