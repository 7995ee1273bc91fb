"""Shared fixtures: shipped runs from ``data/`` and small measured-run CSV trees in tmp_path.

Nothing here reads ``shared/``: synthetic runs are generated, real rows come from the
shipped copy in ``data/`` (:func:`terrain.io.shipped.read_shipped`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import settings

from terrain.io.shipped import default_data_dir, read_shipped
from terrain.run import IMU_CHANNELS, TIME, Run

# One OpenMP thread per pool for the test session (a value set by the user wins). torch,
# imported later and only where a test needs it, reads this when it loads. The tests train
# tiny CNNs in one process with NumPy's BLAS and numba: with two OpenMP threads torch's
# threads wait on each other whenever a core is busy, and one small fit took 3.8-5.5 s
# instead of 0.15-0.2 s on this 2-core machine (measured 2026-11-26). Library defaults
# outside the tests are unchanged.
os.environ.setdefault("OMP_NUM_THREADS", "1")

# Property tests (Hypothesis) draw new examples on every local run, so they keep exploring;
# under CI (``CI`` set, as ``.ci/run`` sets it) they draw the same ones every time, so a
# landing is judged on the code, not on the luck of one draw (a false property that a draw
# finds is fixed where it was found; the examples of every failure are kept in the test).
settings.register_profile("ci", derandomize=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

#: Column orders of the measured files (``shared/data/README.md``).
IMU_FILE_COLUMNS = ["time", *IMU_CHANNELS]
BOREALTC_PRO_COLUMNS = ["time", "curL", "curR", "velL", "velR"]
#: canonical name -> file column name
FILE_NAMES = {TIME: "time", "vel_l": "velL", "vel_r": "velR", "cur_l": "curL", "cur_r": "curR",
              **{c: c for c in IMU_CHANNELS}}


def _synth_imu(duration_s: float = 10.0, rate_hz: float = 100.0, seed: int = 0
               ) -> pd.DataFrame:
    """IMU frame with *file* column names, rad/s and m/s^2, time i / rate_hz (exact)."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    gyro = 0.05 * rng.standard_normal((n, 3))
    acc = 0.3 * rng.standard_normal((n, 3)) + np.array([0.0, 0.0, 9.81])
    return pd.DataFrame(np.column_stack([t, gyro, acc]), columns=IMU_FILE_COLUMNS)


def _synth_pro(duration_s: float = 10.0, rate_hz: float = 10.0, seed: int = 1,
               columns: list[str] = BOREALTC_PRO_COLUMNS) -> pd.DataFrame:
    """Wheel frame with *file* column names in the given order (m/s, A)."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz)) + 1
    data = {"time": np.arange(n) / rate_hz,
            "velL": 0.5 + 0.02 * rng.standard_normal(n),
            "velR": 0.6 + 0.02 * rng.standard_normal(n),
            "curL": 5.0 + rng.standard_normal(n),
            "curR": 7.0 + rng.standard_normal(n)}
    return pd.DataFrame(data)[columns]


def _write_run(root: Path, terrain: str, index: str, imu: pd.DataFrame | None = None,
               pro: pd.DataFrame | None = None) -> dict[str, Path]:
    """Write ``<root>/<terrain>/{imu,pro}_<index>.csv``; returns ``kind -> path``."""
    folder = Path(root) / terrain
    folder.mkdir(parents=True, exist_ok=True)
    paths = {}
    for kind, frame in (("imu", imu), ("pro", pro)):
        if frame is not None:
            paths[kind] = folder / f"{kind}_{index}.csv"
            frame.to_csv(paths[kind], index=False)
    return paths


def _to_file_frame(frame: pd.DataFrame, columns: list[str]) -> pd.DataFrame:
    """A canonical stream frame renamed to file column names, in ``columns`` order."""
    return frame.rename(columns=FILE_NAMES)[columns]


@pytest.fixture
def synth_imu():
    """Factory of synthetic IMU frames (file column names)."""
    return _synth_imu


@pytest.fixture
def synth_pro():
    """Factory of synthetic wheel frames (file column names, chosen order)."""
    return _synth_pro


@pytest.fixture
def write_run():
    """Writer of one run's CSV files into a measured-run tree."""
    return _write_run


@pytest.fixture
def to_file_frame():
    """Renamer from canonical to file column names."""
    return _to_file_frame


@pytest.fixture
def make_run():
    """Build a :class:`Run` in memory from canonical stream frames."""
    def make(streams: dict[str, pd.DataFrame], run_id: str = "test/ASPHALT/00",
             terrain: str | None = "ASPHALT") -> Run:
        return Run(run_id=run_id, dataset=run_id.split("/")[0], terrain=terrain,
                   streams=streams, source="in-memory test run")
    return make


@pytest.fixture
def steady_husky_run():
    """``make(imu_shift_s=0.0)``: 5 s of a Husky in a steady turn (wheels 0.5 / 0.6 m/s, gyro
    0.2 rad/s, level), both streams at 100 Hz, the IMU's clock shifted by ``imu_shift_s``."""
    def make(imu_shift_s: float = 0.0) -> Run:
        t = np.arange(0.0, 5.0, 0.01)
        wheels = pd.DataFrame({"t_s": t, "vel_l": 0.5 + 0 * t, "vel_r": 0.6 + 0 * t})
        imu = pd.DataFrame({"t_s": t + imu_shift_s, "wz": 0.2 + 0 * t, "ax": 0 * t,
                            "ay": 0 * t, "az": 9.81 + 0 * t})
        return Run(run_id="test/ASPHALT/00", dataset="test", terrain="ASPHALT",
                   streams={"wheels": wheels, "imu": imu}, source="in-memory test run")
    return make


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The shipped ``data/`` folder of the repository."""
    path = default_data_dir()
    assert (path / "manifest.json").exists(), f"shipped data missing at {path}"
    return path


@pytest.fixture(scope="session")
def borealtc_runs(data_dir):
    """Every shipped BorealTC run."""
    return read_shipped("borealtc", data_dir)


@pytest.fixture(scope="session")
def vulpi_runs(data_dir):
    """Every shipped Vulpi run."""
    return read_shipped("vulpi", data_dir)


class _LoggedRun:
    """Stand-in of :func:`terrain.tracking.tracked_run`'s run: keeps the metrics logged."""

    def __init__(self, logged: dict) -> None:
        self.logged = logged

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def log_metrics(self, metrics):
        self.logged.update(metrics)

    def describe(self):
        return "run"


@pytest.fixture
def logged_metrics(monkeypatch):
    """Route a benchmark script's MLflow run to a dict: call with the script's globals
    (``runpy.run_path(...)["main"].__globals__``, or a module's ``vars()``); returns the
    dict its metrics land in."""
    def capture(script_globals: dict) -> dict:
        logged: dict = {}
        monkeypatch.setitem(script_globals, "tracked_run", lambda *a, **k: _LoggedRun(logged))
        return logged
    return capture
