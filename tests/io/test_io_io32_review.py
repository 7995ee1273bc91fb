"""Review io32 of the measured-run writer and readers (:mod:`terrain.io.writer`,
:mod:`terrain.io.measured`): a run the writer takes reads back with its streams, values and
metadata; what it cannot write as it is, it refuses before writing anything."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError, DataFormatError, MissingColumnError, TimestampError
from terrain.io.align import align_streams
from terrain.io.measured import read_runs_dir, read_runs_path
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run

_SETTINGS = dict(max_examples=15, deadline=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])


def _run(t0_s: float = 0.0, n_wheels: int = 40, extra=None, meta=None,
         terrain: str = "ASPHALT") -> Run:
    """A small Husky run (100 Hz IMU, 6.5 Hz wheels) whose clocks start at ``t0_s``."""
    rng = np.random.default_rng(0)
    n_imu = int(n_wheels / 6.5 * 100)
    imu = pd.DataFrame({TIME: t0_s + np.arange(n_imu) / 100.0,
                        **{c: rng.normal(0.0, 0.1, n_imu) for c in IMU_CHANNELS}})
    imu["az"] += 9.81
    wheels = pd.DataFrame({TIME: t0_s + np.arange(n_wheels) / 6.5,
                           **{c: rng.uniform(0.0, 0.5, n_wheels) for c in WHEEL_CHANNELS}})
    streams = {"imu": imu, "wheels": wheels, **(extra or {})}
    return Run(run_id="x/A/00", dataset="x", terrain=terrain, streams=streams,
               meta=meta or {})


def _read_back(root):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        runs = read_runs_dir(root)
    assert len(runs) == 1
    return runs[0]


def _no_file(root) -> bool:
    return not any(p.is_file() for p in root.rglob("*"))


_NOT_TEXT_NOR_NUMBER = {
    # (each was written as its text, "2020-01-01 00:00:00", "0 days 00:00:01", "(1+2j)",
    # "b'a'", and read back as a text channel: other values, another type, without a word)
    "datetime": lambda n: pd.date_range("2020-01-01", periods=n, freq="s"),
    "timedelta": lambda n: pd.to_timedelta(np.arange(n), "s"),
    "complex": lambda n: np.arange(n) + 2j,
    "bytes": lambda n: [b"GRASS"] * n,
    "complex_objects": lambda n: pd.Series([complex(k, 1) for k in range(n)], dtype=object),
    "boolean_objects": lambda n: pd.Series([k % 2 == 0 for k in range(n)], dtype=object),
    "numpy_durations": lambda n: pd.Series([np.timedelta64(k, "s") for k in range(n)],
                                           dtype=object),
    "periods": lambda n: pd.period_range("2020-01", periods=n, freq="M"),
}


@settings(**_SETTINGS)
@given(kind=st.sampled_from(sorted(_NOT_TEXT_NOR_NUMBER)),
       stream=st.sampled_from(["truth", "extra2"]), n=st.integers(2, 12))
def test_a_column_neither_numbers_nor_text_is_refused_before_writing(tmp_path_factory, kind,
                                                                     stream, n):
    root = tmp_path_factory.mktemp("out")
    frame = pd.DataFrame({TIME: np.arange(n) / 10.0,
                          "value": _NOT_TEXT_NOR_NUMBER[kind](n)})
    with pytest.raises(ConfigError, match=rf"stream '{stream}'.*column 'value'"):
        write_run(_run(extra={stream: frame}), root, 0)
    assert _no_file(root)


@pytest.mark.parametrize("terrain", ["A\x00B", "\x00"])
def test_a_terrain_with_a_nul_character_is_refused_not_a_bare_value_error(tmp_path, terrain):
    # mkdir / exists raised Python's bare "ValueError: embedded null byte"
    with pytest.raises(ConfigError, match="not a folder name"):
        write_run(_run(terrain=terrain), tmp_path, 0)
    assert _no_file(tmp_path)


_CLOCKS = {
    # (text: float()'s bare "could not convert string to float: 'a'"; a np.timedelta64 among
    # objects: math.isinf's bare TypeError; a date or a duration: written as its text)
    "text": lambda n: [f"t{k}" for k in range(n)],
    "pandas_text": lambda n: pd.array([f"t{k}" for k in range(n)], dtype="string"),
    "dates": lambda n: pd.date_range("2020-01-01", periods=n, freq="s"),
    "durations": lambda n: pd.to_timedelta(np.arange(n), "s"),
    "numpy_durations": lambda n: pd.Series([np.timedelta64(k, "s") for k in range(n)],
                                           dtype=object),
    "complex": lambda n: np.arange(n) + 0j,
}


@settings(**_SETTINGS)
@given(kind=st.sampled_from(sorted(_CLOCKS)), stream=st.sampled_from(["wheels", "truth"]))
def test_a_clock_that_is_not_numbers_is_refused_naming_stream_and_row(tmp_path_factory, kind,
                                                                      stream):
    root = tmp_path_factory.mktemp("out")
    run = _run(extra={"truth": pd.DataFrame({TIME: np.arange(5) / 10.0, "x": np.ones(5)})})
    frame = run.streams[stream].copy()
    frame[TIME] = _CLOCKS[kind](len(frame))
    streams = {**run.streams, stream: frame}
    run = Run(run.run_id, run.dataset, run.terrain, streams)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # (NumPy's ComplexWarning, were it cast)
        with pytest.raises(ConfigError, match=rf"stream '{stream}'.*timestamp .* at row 0 "
                                              "is not a number"):
            write_run(run, root, 0)
    assert _no_file(root)


def _aligned(imu: pd.DataFrame, rate_hz: float = 10.0) -> pd.DataFrame:
    """``imu`` aligned beside a 20-sample wheel stream at 10 Hz."""
    wheels = pd.DataFrame({TIME: np.arange(20) / 10.0, "vel_l": np.ones(20)})
    return align_streams(Run("x/A/00", "x", None, {"imu": imu, "wheels": wheels}),
                         rate_hz=rate_hz)


@pytest.mark.parametrize("columns, twice", [
    # (each was a bare error: "'DataFrame' object has no attribute 'dtype'", and for t_s
    # "operands could not be broadcast together with shapes (20,1) (19,2)")
    ([TIME, "ax", "ax"], "ax"), ([TIME, TIME, "ax"], TIME), ([TIME, "ax", "ay", "ax"], "ax")])
def test_a_stream_with_a_column_twice_is_refused_naming_it(columns, twice):
    imu = pd.DataFrame(np.tile(np.arange(20) / 10.0, (len(columns), 1)).T, columns=columns)
    with pytest.raises(DataFormatError, match=rf"stream 'imu'.*{twice!r}"):
        _aligned(imu)


def test_a_stream_without_a_clock_is_refused_naming_it():
    # (a bare KeyError 't_s')
    with pytest.raises(MissingColumnError, match=r"stream 'imu' lacks columns \['t_s'\]"):
        _aligned(pd.DataFrame({"ax": np.arange(20.0)}))


@pytest.mark.parametrize("clock", [
    # booleans were read as the times 0 and 1 s; text as the numbers it spells
    pd.Series([False, True] * 10), pd.array([False, True] * 10, dtype="boolean"),
    pd.Series([f"{k / 10}" for k in range(20)]),
    pd.array([f"{k / 10}" for k in range(20)], dtype="string")])
def test_a_clock_of_booleans_or_text_is_refused(clock):
    with pytest.raises(TimestampError, match=r"stream 'imu'.*timestamps must be numbers"):
        _aligned(pd.DataFrame({TIME: clock, "ax": np.arange(20.0)}))


@pytest.mark.parametrize("cell", ["0.7", b"0.7", True])
def test_a_clock_of_numbers_holding_one_text_or_boolean_stamp_is_refused_naming_its_row(
        cell):
    clock = pd.Series(list(np.arange(20) / 10), dtype=object)
    clock[7] = cell
    with pytest.raises(TimestampError, match=r"stream 'imu'.*numbers \(s\), got .* at "
                                             r"row 7") as err:
        _aligned(pd.DataFrame({TIME: clock, "ax": np.arange(20.0)}))
    assert err.value.row == 7


@pytest.mark.slow
@settings(max_examples=20, deadline=None)
@given(dtype=st.sampled_from(["float64", "float32", "int64", "object"]),
       n=st.integers(2, 30), rate=st.sampled_from([1.0, 2.0, 4.0]))
def test_a_numeric_clock_of_any_dtype_is_aligned_as_its_float_values(dtype, n, rate):
    # (a stream no faster than the grid: not filtered, a line interpolated exactly)
    t = np.arange(n, dtype=float)
    imu = pd.DataFrame({TIME: pd.Series(t).astype(dtype), "ax": 2.0 * t})
    wheels = pd.DataFrame({TIME: t, "vel_l": np.ones(n)})
    frame = align_streams(Run("x/A/00", "x", None, {"imu": imu, "wheels": wheels}),
                          rate_hz=rate)
    np.testing.assert_allclose(frame["ax"], 2.0 * frame[TIME], rtol=1e-12)


@pytest.mark.parametrize("terrain", ["\udcff", "A\udcffB", "\ud800", "GRASS\udfff"])
def test_a_terrain_with_a_lone_surrogate_is_refused_before_writing(tmp_path, terrain):
    # '\udcff' was written as the folder b'\xff' and read back as the label '\\XFF' (the
    # readers escape a byte that is not UTF-8, then upper-case the name); '\ud800' failed
    # in a bare UnicodeEncodeError 'surrogates not allowed'
    with pytest.raises(ConfigError, match="not UTF-8 text"):
        write_run(_run(terrain=terrain), tmp_path, 0)
    assert _no_file(tmp_path)


@pytest.mark.slow
@settings(**_SETTINGS)
@given(terrain=st.text(min_size=1, max_size=8))
def test_a_terrain_the_writer_takes_is_read_back_as_the_runs_label(tmp_path_factory,
                                                                   terrain):
    root = tmp_path_factory.mktemp("out")
    try:
        write_run(_run(n_wheels=6, terrain=terrain), root, 0)
    except ConfigError:
        assert _no_file(root)
        return
    back = _read_back(root)
    assert back.terrain == terrain
    assert back.run_id.split("/")[1:] == [terrain, "00"]


@pytest.mark.parametrize("vehicle", ["car", "", None, 3, "husky ", "HUSKY\n"])
def test_a_run_of_a_vehicle_the_readers_do_not_know_is_refused_before_writing(tmp_path,
                                                                              vehicle):
    # its files were written, then the readers refused meta_00.json ("key 'vehicle':
    # unknown vehicle 'car'"), which stopped the reading of every run of the folder
    run = _run(n_wheels=6)
    run = Run(run.run_id, run.dataset, run.terrain, run.streams, vehicle=vehicle)
    with pytest.raises(ConfigError, match=r"vehicle .*valid: agrimaro, husky, tracked"):
        write_run(run, tmp_path, 0)
    assert _no_file(tmp_path)


@pytest.mark.parametrize("vehicle", ["agrimaro", "husky", "tracked", "Tracked"])
def test_a_run_of_a_known_vehicle_is_read_back_as_that_vehicle(tmp_path, vehicle):
    run = _run(n_wheels=6)
    write_run(Run(run.run_id, run.dataset, run.terrain, run.streams, vehicle=vehicle),
              tmp_path, 0)
    assert _read_back(tmp_path).vehicle == vehicle.lower()


def _quantised_run(t0_s: float, imu_hz: float, wheel_hz: float, seconds: float, seed: int,
                   terrain: str) -> Run:
    """A run whose values are multiples of 1/64 (``%.9g`` writes them exactly) and whose
    clocks ``t0_s + k / rate`` read back exactly (from 0 at a rate whose period is a short
    decimal: each ``k / rate`` is the double nearest its text; at 1.7e9 s the writer writes
    every float in full). (At 6.5 Hz ``%.9g`` moves a stamp by up to 5e-9 of it, as the
    writer documents, and the aligned values by a few units in the last place.)"""
    rng = np.random.default_rng(seed)
    n_imu, n_wheels = int(seconds * imu_hz), int(seconds * wheel_hz)
    imu = pd.DataFrame({TIME: t0_s + np.arange(n_imu) / imu_hz,
                        **{c: rng.integers(-8, 8, n_imu) / 64 for c in IMU_CHANNELS}})
    imu["az"] += 9.8125
    wheels = pd.DataFrame({TIME: t0_s + np.arange(n_wheels) / wheel_hz,
                           **{c: rng.integers(0, 32, n_wheels) / 64 for c in WHEEL_CHANNELS}})
    labels = np.array(["ASPHALT", "GRASS", "ÉTÉ_☃"])[rng.integers(0, 3, n_wheels)]
    truth = pd.DataFrame({TIME: wheels[TIME], "terrain": labels,
                          "slip": rng.integers(-64, 64, n_wheels) / 64})
    return Run(run_id="x/A/00", dataset="x", terrain=terrain,
               streams={"imu": imu, "wheels": wheels, "truth": truth},
               meta={"note": "piste d'été ☃", "seed": seed, "rates": [imu_hz, wheel_hz]})


@pytest.mark.slow
@settings(**{**_SETTINGS, "max_examples": 8})
@given(t0=st.sampled_from([0.0, 1.7e9]), imu_hz=st.sampled_from([50.0, 100.0, 200.0]),
       wheel_hz=st.sampled_from([5.0, 8.0, 10.0, 12.5, 20.0]), seconds=st.integers(3, 6),
       seed=st.integers(0, 2 ** 16), terrain=st.sampled_from(["ASPHALT", "ÉTÉ", "ПЕСОК"]),
       rate_hz=st.sampled_from([10.0, 20.0, 50.0]))
def test_a_written_run_reads_back_and_aligns_bit_for_bit(tmp_path_factory, t0, imu_hz,
                                                         wheel_hz, seconds, seed, terrain,
                                                         rate_hz):
    run = _quantised_run(t0, imu_hz, wheel_hz, seconds, seed, terrain)
    root = tmp_path_factory.mktemp("out")
    write_run(run, root, 0)
    back = _read_back(root)
    assert (back.terrain, back.vehicle, back.run_id) == (terrain, "husky", f"{root.name}/"
                                                                           f"{terrain}/00")
    assert set(back.streams) == set(run.streams)
    for name, frame in run.streams.items():
        pd.testing.assert_frame_equal(back.streams[name][list(frame.columns)], frame,
                                      check_dtype=False)
    assert {k: back.meta[k] for k in run.meta} == run.meta
    assert not back.meta["repaired"] and not back.meta["gaps"]
    streams = ("imu", "wheels", "truth")
    aligned = align_streams(back, streams, rate_hz)
    pd.testing.assert_frame_equal(aligned, align_streams(run, streams, rate_hz),
                                  check_exact=True)
    # the text labels are left out of the aligned frame, and counted
    assert aligned.attrs["dropped_columns"] == ("truth.terrain",)
    assert aligned.attrs["n_dropped_columns"] == 1
    assert list(aligned.columns) == [TIME, *IMU_CHANNELS, *WHEEL_CHANNELS, "slip"]


@st.composite
def _slow_streams(draw):
    """Two streams no faster than the grid (not filtered), each at its own rate and clock
    offset (from 0 or at the 1.7e9 s epoch), with random values and no gap."""
    origin = draw(st.sampled_from([0.0, 1234.5, 1.7e9]))
    streams = {}
    for name, channel in (("imu", "ax"), ("wheels", "vel_l")):
        rate = draw(st.sampled_from([3.0, 6.5, 10.0, 15.0]))
        n = draw(st.integers(2, 40))
        offset = draw(st.floats(0.0, 1.0))
        values = draw(st.lists(st.floats(-1e3, 1e3), min_size=n, max_size=n))
        streams[name] = pd.DataFrame({TIME: origin + offset + np.arange(n) / rate,
                                      channel: values})
    return streams


@settings(max_examples=60, deadline=None)
@given(streams=_slow_streams())
def test_the_aligned_grid_never_extrapolates_past_a_streams_samples(streams):
    run = Run("x/A/00", "x", None, streams)
    t0 = max(f[TIME].iloc[0] for f in streams.values())
    t1 = min(f[TIME].iloc[-1] for f in streams.values())
    if t1 <= t0:
        with pytest.raises(DataFormatError, match="do not overlap"):
            align_streams(run, rate_hz=10.0)
        return
    frame = align_streams(run, rate_hz=10.0)
    t = frame[TIME].to_numpy()
    assert t[0] == t0 and t[-1] <= t1 + 1e-9 and t1 - t[-1] < 0.1 + 1e-9
    for f in streams.values():
        channel = f.columns[1]
        ts, vs = f[TIME].to_numpy(), f[channel].to_numpy()
        # each grid value lies between the two samples around it: a linear interpolation
        j = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 2)
        lo = np.minimum(vs[j], vs[j + 1])
        hi = np.maximum(vs[j], vs[j + 1])
        got = frame[channel].to_numpy()
        assert np.isfinite(got).all()
        slack = 1e-12 * np.maximum(1.0, np.abs(vs).max())
        assert (got >= lo - slack).all() and (got <= hi + slack).all()


@pytest.mark.parametrize("only", ["ASPHALT/", "/ASPHALT", "", ".", "..", "../ASPHALT",
                                  "A\x00", 3, Path("ASPHALT")])
def test_read_runs_dir_only_names_one_terrain_folder_of_the_root(tmp_path, only):
    # 'ASPHALT/' read the run as '<root>/ASPHALT//00' labelled 'ASPHALT/'; '' looked for
    # run files in the root itself, '../ASPHALT' outside it; 3 a bare TypeError
    write_run(_run(n_wheels=6), tmp_path, 0)
    with pytest.raises(ConfigError, match=r"read_runs_dir.only names one terrain folder"):
        read_runs_dir(tmp_path, only=only)


@pytest.mark.parametrize("only", ["NOPE", "asphalt"])
def test_read_runs_dir_only_naming_no_folder_is_a_data_format_error_listing_them(
        tmp_path, only):
    # (a bare FileNotFoundError)
    write_run(_run(n_wheels=6), tmp_path, 0)
    with pytest.raises(DataFormatError, match=rf"no terrain folder {only!r}.*'ASPHALT'"):
        read_runs_dir(tmp_path, only=only)


def test_read_runs_dir_only_and_read_runs_path_read_one_terrain_folder_alike(tmp_path):
    write_run(_run(n_wheels=6), tmp_path, 0)
    write_run(_run(n_wheels=6, terrain="ÉTÉ"), tmp_path, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        (one,) = read_runs_dir(tmp_path, only="ÉTÉ")
        (other,) = read_runs_path(tmp_path / "ÉTÉ")
    assert one.run_id == other.run_id == f"{tmp_path.name}/ÉTÉ/00"
    assert one.terrain == other.terrain == "ÉTÉ"


def test_read_runs_path_reads_a_terrain_folder_whose_name_holds_a_backslash(tmp_path):
    # (a file name character on POSIX: read_runs_path passes it as read_runs_dir's only)
    folder = tmp_path / "A\\B"
    write_run(_run(n_wheels=6), tmp_path, 0)
    (tmp_path / "ASPHALT").rename(folder)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        (run,) = read_runs_path(folder)
    assert run.terrain == "A\\B"
