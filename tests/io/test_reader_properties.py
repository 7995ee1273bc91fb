"""Property tests of the readers: random perturbations of real files, and clocks in s, ms, us
or ns.

For any mix of cell corruption, byte flips, dropped, duplicated or shuffled rows, blank lines
and ragged rows applied to real rows of a shipped run, :func:`read_runs_dir` returns a valid
:class:`~terrain.run.Run` or raises the project's own :class:`~terrain.errors.TerrainError`,
never anything else (no ``UnicodeDecodeError``, ``IndexError``, pandas or numpy error). For
any stream clock at any rate and in any unit, the readers refuse it exactly when the
streaming service does (rule ``timestamp_units``).
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrain.errors import TerrainError, UnitError
from terrain.io.measured import read_runs_dir
from terrain.io.plausibility import NOMINAL_RATE_HZ, TIME_UNITS, check_rate
from terrain.serving.clocks import UNITS_STEPS, clock_in_ms
from terrain.run import TIME, Run

N_ROWS = {"imu": 300, "pro": 40}  # 3 s of IMU, 6 s of wheel reports: small and quick


@pytest.fixture(scope="module")
def real_files(borealtc_runs) -> dict[str, bytes]:
    """The first rows of a real BorealTC run, as the CSV files of the measured layout."""
    run = next(r for r in borealtc_runs if r.run_id == "borealtc/ASPHALT/00")
    imu = run.streams["imu"].rename(columns={TIME: "time"}).head(N_ROWS["imu"])
    pro = run.streams["wheels"].rename(columns={TIME: "time", "vel_l": "velL", "vel_r": "velR",
                                                "cur_l": "curL", "cur_r": "curR"})
    pro = pro[["time", "curL", "curR", "velL", "velR"]].head(N_ROWS["pro"])
    return {"imu": imu.to_csv(index=False).encode(), "pro": pro.to_csv(index=False).encode()}


def _apply(data: bytes, op: tuple) -> bytes:
    kind = op[0]
    if kind == "flip":
        _, pos, value = op
        b = bytearray(data)
        b[pos % len(b)] = value
        return bytes(b)
    lines = data.split(b"\n")
    i = 1 + op[1] % max(1, len(lines) - 2)  # a data line (never the header)
    if kind == "cell":
        fields = lines[i].split(b",")
        fields[op[2] % len(fields)] = op[3].encode("utf-8", "surrogatepass")
        lines[i] = b",".join(fields)
    elif kind == "drop":
        del lines[i]
    elif kind == "duplicate":
        lines.insert(i, lines[i])
    elif kind == "swap":
        j = 1 + op[2] % max(1, len(lines) - 2)
        lines[i], lines[j] = lines[j], lines[i]
    elif kind == "blank":
        lines.insert(i, b"")
    elif kind == "ragged":
        lines[i] = lines[i] + b",0" if op[2] % 2 else lines[i].rsplit(b",", 1)[0]
    return b"\n".join(lines)


_index = st.integers(min_value=0, max_value=10_000)
_cell = st.one_of(st.text(max_size=8), st.sampled_from(
    ["nan", "inf", "-inf", "", "1e300", "-1e308", "0x1F", '"', "1,5", "NaN", "\x00", "\ufeff"]))
_op = st.one_of(
    st.tuples(st.just("flip"), _index, st.integers(0, 255)),
    st.tuples(st.just("cell"), _index, _index, _cell),
    st.tuples(st.sampled_from(["drop", "duplicate", "blank"]), _index),
    st.tuples(st.sampled_from(["swap", "ragged"]), _index, _index),
)


def _check_valid(run: Run) -> None:
    assert set(run.streams) == {"imu", "wheels"}
    for frame in run.streams.values():
        t = frame[TIME].to_numpy()
        assert len(t) >= 2 and np.all(np.diff(t) > 0)
        assert np.isfinite(frame.to_numpy(dtype=float)).all()


@pytest.mark.slow
@settings(max_examples=100, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=st.lists(st.tuples(st.sampled_from(["imu", "pro"]), _op), min_size=1, max_size=4))
def test_perturbed_real_files_give_a_run_or_a_project_error(real_files, ops):
    files = dict(real_files)
    for which, op in ops:
        files[which] = _apply(files[which], op)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "ASPHALT"
        folder.mkdir()
        for which, data in files.items():
            (folder / f"{which}_00.csv").write_bytes(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # DataWarnings are allowed answers
            try:
                runs = read_runs_dir(tmp)
            except TerrainError as exc:
                assert "\n" not in str(exc) and len(str(exc)) < 1000
                return
    assert len(runs) == 1
    _check_valid(runs[0])


@settings(max_examples=300, deadline=None, derandomize=True)
@given(stream=st.sampled_from(sorted(NOMINAL_RATE_HZ)),
       rate_hz=st.floats(0.5, 3000.0),
       unit=st.sampled_from(["s", *TIME_UNITS]),
       t0=st.sampled_from([0.0, 12.5, 1.7e9]),
       n=st.integers(UNITS_STEPS + 1, 60))
def test_readers_and_service_refuse_the_same_clock_units(stream, rate_hz, unit, t0, n):
    """``check_rate`` (readers) raises UnitError exactly when ``clock_in_ms`` (service) finds
    the clock in another unit, and a clock at a nominal rate in ms, us or ns is refused naming
    its unit. Before, the readers judged ms only: an IMU at 100 Hz in us (1e-4 Hz read as s)
    or ns (1e-7 Hz) was a warning, while the service refused it."""
    per_s = TIME_UNITS[unit][0] if unit in TIME_UNITS else 1.0
    t = (t0 + np.arange(n) / rate_hz) * per_s
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # rates outside the range are warnings
        try:
            check_rate(t, stream, "f.csv")
            refused = None
        except UnitError as exc:
            assert exc.path == "f.csv" and exc.column == "time"
            refused = str(exc)
    assert (refused is not None) == clock_in_ms(t, stream)
    lo, hi = NOMINAL_RATE_HZ[stream]
    fits = [u for u, (k, _, _) in TIME_UNITS.items() if lo <= k * rate_hz / per_s <= hi]
    if unit in TIME_UNITS and lo * 1.01 <= rate_hz <= hi * 0.99 and rate_hz / per_s < lo / 10:
        assert refused is not None, (rate_hz, unit)
        if fits == [unit]:   # a wheel clock at 1000 Hz in us is also one at 1 Hz in ms
            assert f"({unit})" in refused
