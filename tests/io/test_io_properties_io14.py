"""Property tests of the measured-run readers, the writer and the alignment (review io14).

* :func:`write_run` then :func:`read_runs_dir` gives back every stream (an extra stream with
  arbitrary finite values and channel names included) to 9 significant digits, every
  timestamp still strictly increasing, and the JSON metadata as written;
* :func:`align_streams` puts the streams on a uniform grid at the asked rate inside their
  overlap, reproduces a linear signal, never bridges a gap and bridges one missing sample;
* the reader's repair of isolated non-finite cells is counted exactly (the count is the
  number of cells repaired), never repairs a burst longer than ``max_repair_run`` and names
  the file, column and line of the first burst it refuses;
* a valid file corrupted at the byte level (a truncated line, two rows swapped, a row
  duplicated, a non-numeric cell, a NaN burst) is a typed :class:`DataFormatError` naming
  file and line (and column where one is at fault), or a counted repair: never a bare
  exception, never read silently.
"""

from __future__ import annotations

import json
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import (DataFormatError, NonFiniteError, NonNumericError, RaggedRowError,
                            TimestampError)
from terrain.io.align import align_streams
from terrain.io.measured import read_runs_dir, read_stream_csv
from terrain.io.plausibility import CHANNEL_LIMITS
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run

FAST = settings(max_examples=30, deadline=None, derandomize=True)


def _quiet_read(root, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # plausibility warnings on random values
        return read_runs_dir(root, **options)


# --- write_run -> read_runs_dir ------------------------------------------------------------

_finite = st.floats(allow_nan=False, allow_infinity=False)
_channel = st.from_regex(r"[a-z][a-z0-9_]{0,6}", fullmatch=True).filter(
    lambda c: c not in ("time", TIME) and c not in CHANNEL_LIMITS)   # (ranges of their own)
_json_scalar = st.one_of(st.none(), st.booleans(), st.integers(-2**53, 2**53), _finite,
                         st.text(max_size=6))
_json_value = st.recursive(_json_scalar, lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=4), inner, max_size=3)),
    max_leaves=8)


@st.composite
def written_runs(draw) -> Run:
    """A valid run: IMU and wheels of plausible values, an extra stream of arbitrary finite
    values, a clock from any offset (an epoch clock included), JSON metadata."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    t0 = draw(st.sampled_from([0.0, 0.37, 1234.5678, 1.7e9 + 0.123]))
    span = draw(st.floats(1.0, 3.0))
    n_imu = int(span * 100)
    t_imu = t0 + np.r_[0.0, np.cumsum(rng.uniform(0.008, 0.012, n_imu - 1))]
    t_pro = t0 + np.linspace(0, span, draw(st.integers(8, 20))) + rng.uniform(0, 1e-3)
    n_i, n_p = len(t_imu), len(t_pro)
    imu = pd.DataFrame({TIME: t_imu, **{c: rng.normal(0.0, 0.2, n_i) for c in IMU_CHANNELS}})
    imu["az"] = 9.81 + rng.normal(0.0, 0.5, n_i)
    wheels = pd.DataFrame({TIME: t_pro, **{c: rng.uniform(0.0, 0.8 if "vel" in c else 20, n_p)
                                           for c in WHEEL_CHANNELS}})
    names = draw(st.lists(_channel, min_size=1, max_size=3, unique=True))
    n_x = draw(st.integers(2, 12))
    t_x = t0 + np.linspace(0, span, n_x)
    extra = pd.DataFrame({TIME: t_x, **{c: np.array(draw(st.lists(
        _finite, min_size=n_x, max_size=n_x))) for c in names}})
    meta = draw(st.dictionaries(st.from_regex(r"k_[a-z]{1,5}", fullmatch=True), _json_value,
                                max_size=4))
    return Run(run_id="gen/SNOW/00", dataset="gen", terrain="SNOW",
               streams={"imu": imu, "wheels": wheels, "truth": extra}, vehicle="husky",
               source="", meta=meta)


def _json_equal(a, b) -> bool:
    """JSON values alike, NaN written as null (the writer's documented rule)."""
    if isinstance(a, float) and np.isnan(a):
        return b is None
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(
            _json_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return isinstance(b, list) and len(a) == len(b) and all(map(_json_equal, a, b))
    return type(a) is type(b) and a == b


@pytest.mark.slow
@FAST
@given(run=written_runs())
def test_any_valid_run_reads_back_to_nine_significant_digits(run):
    with tempfile.TemporaryDirectory() as tmp:
        paths = write_run(run, tmp)
        (back,) = _quiet_read(tmp)
        written_meta = json.loads(paths["meta"].read_text())
    assert back.run_id == f"{Path(tmp).name}/SNOW/00"
    assert back.terrain == "SNOW" and back.vehicle == "husky"
    assert set(back.streams) == set(run.streams)
    for name, frame in run.streams.items():
        got = back.streams[name]
        assert list(got.columns) == list(frame.columns)
        assert len(got) == len(frame)
        t = got[TIME].to_numpy()
        assert np.all(np.diff(t) > 0)                     # still strictly increasing
        want = frame.to_numpy(dtype=float)
        np.testing.assert_allclose(got.to_numpy(dtype=float), want, rtol=5e-9, atol=0)
    assert back.meta["repaired"] == {} and back.meta["gaps"] == {}
    for key, value in run.meta.items():
        assert _json_equal(value, written_meta[key]), key
        assert _json_equal(value, back.meta[key]), key


# --- align_streams -------------------------------------------------------------------------

def make_run(streams: dict[str, pd.DataFrame]) -> Run:
    return Run(run_id="t/SNOW/00", dataset="t", terrain="SNOW", streams=streams,
               source="in-memory")


def _stream(t, name, alpha, beta):
    return pd.DataFrame({TIME: t, name: alpha + beta * t})


@st.composite
def linear_runs(draw):
    """A grid rate and two streams of linear signals with different spans and rates, on
    clocks jittered by up to 10 % (a uniform one for a stream the alignment filters: the
    filter takes its samples for evenly spaced)."""
    rate_hz = draw(st.sampled_from([10.0, 25.0, 50.0, 100.0]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    streams, coeffs = {}, {}
    for name, channel in (("a", "x"), ("b", "y")):
        rate = draw(st.sampled_from([6.5, 12.0, 50.0, 100.0, 333.0]))
        start = draw(st.floats(0.0, 1.0))
        n = int(draw(st.floats(3.0, 6.0)) * rate)
        jitter = 0.1 if 1.2 * rate <= 1.5 * rate_hz else 0.0   # (a median step 10 % off)
        steps = np.full(n - 1, 1.0 / rate) * (1 + rng.uniform(-jitter, jitter, n - 1))
        t = start + np.r_[0.0, np.cumsum(steps)]
        alpha, beta = draw(st.floats(-10, 10)), draw(st.floats(-5, 5))
        streams[name] = _stream(t, channel, alpha, beta)
        coeffs[channel] = (alpha, beta, rate / rate_hz)
    return rate_hz, streams, coeffs


@FAST
@given(data=linear_runs())
def test_aligned_grid_is_uniform_inside_the_overlap_and_linear_signals_are_kept(data):
    rate_hz, streams, coeffs = data
    frame = align_streams(make_run(streams), ("a", "b"), rate_hz=rate_hz)
    t = frame[TIME].to_numpy()
    lo = max(s[TIME].iloc[0] for s in streams.values())
    hi = min(s[TIME].iloc[-1] for s in streams.values())
    assert t[0] == lo and t[-1] <= hi + 1e-9 and t[-1] + 1 / rate_hz > hi - 1e-9
    np.testing.assert_allclose(np.diff(t), 1 / rate_hz, rtol=1e-9)
    assert frame.attrs["rate_hz"] == rate_hz
    for channel, (alpha, beta, ratio) in coeffs.items():
        span = abs(beta) * (hi - lo)
        # interpolation is exact for a linear signal; the anti-alias filter of a fast
        # stream (zero phase, odd extension) keeps a ramp to 1e-5 of its span at twice the
        # grid rate, less at a higher rate (the module's docstring)
        tol = 1e-9 if ratio <= 1.5 else 1e-5 if ratio <= 2 else 3e-3 if ratio <= 10 else 2.5e-2
        np.testing.assert_allclose(frame[channel].to_numpy(), alpha + beta * t, rtol=0,
                                   atol=tol * span + 1e-9)


@FAST
@given(rate=st.sampled_from([6.5, 15.0, 50.0, 100.0]), n=st.integers(20, 80),
       where=st.floats(0.1, 0.9), missing=st.sampled_from([1, 3, 4, 5, 8]),
       beta=st.floats(-3, 3))
def test_a_gap_is_never_bridged_and_one_missing_sample_is(rate, n, where, missing, beta):
    t = np.arange(n) / rate
    k = 1 + int(where * (n - missing - 3))     # samples k .. k + missing - 1 are missing
    # (2 missing: a step of exactly gap_factor = 3 median steps, on the rule's edge)
    keep = np.r_[t[:k], t[k + missing:]]
    ref = _stream(np.arange(4 * n) / (4 * rate), "r", 0.0, 0.0)   # covers the whole span
    run = make_run({"s": _stream(keep, "x", 1.0, beta), "ref": ref})
    frame = align_streams(run, ("s", "ref"), rate_hz=rate * 2)
    grid, x = frame[TIME].to_numpy(), frame["x"].to_numpy()
    inside = (grid > t[k - 1]) & (grid < t[k + missing])
    step = missing + 1                          # the step over the missing samples
    if step > 3:                                # gap_factor 3 x the median step
        assert np.isnan(x[inside]).all() and inside.any()
        assert np.isfinite(x[~inside]).all()
    else:
        assert np.isfinite(x).all()
        np.testing.assert_allclose(x, 1.0 + beta * grid, atol=1e-9)


# --- the reader's repair of non-finite cells -----------------------------------------------

def _write(path: Path, header: list[str], rows: list[list[str]]) -> None:
    path.write_text("\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n")


@FAST
@given(n=st.integers(6, 40), nan_rows=st.sets(st.integers(0, 39), max_size=12),
       max_run=st.integers(0, 3), word=st.sampled_from(["nan", "", "inf", "-nan", "NaN"]))
def test_repairs_are_counted_exactly_and_bursts_refused(tmp_path_factory, n, nan_rows,
                                                        max_run, word):
    path = tmp_path_factory.mktemp("rep") / "truth_00.csv"
    t = np.arange(n) * 0.1
    v = 2.0 + 3.0 * t
    bad = sorted(r for r in nan_rows if r < n)
    rows = [[repr(float(t[i])), word if i in bad else repr(float(v[i])), "1.5"]
            for i in range(n)]
    _write(path, ["time", "v", "w"], rows)
    # the runs of consecutive bad rows, in file order; the first refused one is named
    runs_ = []
    for r in bad:
        if runs_ and runs_[-1][-1] == r - 1:
            runs_[-1].append(r)
        else:
            runs_.append([r])
    refused = next((r for r in runs_ if len(r) > max_run or r[0] == 0 or r[-1] == n - 1),
                   None)
    if refused is not None:
        with pytest.raises(NonFiniteError) as info:
            read_stream_csv(path, "truth", max_repair_run=max_run)
        err = info.value
        assert (err.path, err.column, err.line) == (str(path), "v", refused[0] + 2)
        return
    frame, report = read_stream_csv(path, "truth", max_repair_run=max_run)
    assert report.repaired == ({"v": len(bad)} if bad else {})
    np.testing.assert_allclose(frame["v"].to_numpy(), v, rtol=1e-12)   # linear: exact
    assert all(len(r) <= max_run for r in runs_)


def test_two_consecutive_non_finite_cells_are_never_repaired_with_max_repair_run_1(tmp_path):
    path = tmp_path / "truth_00.csv"
    _write(path, ["time", "v"], [["0", "1"], ["0.1", "nan"], ["0.2", "nan"], ["0.3", "4"]])
    with pytest.raises(NonFiniteError) as info:
        read_stream_csv(path, "truth", max_repair_run=1)
    assert (info.value.column, info.value.line) == ("v", 3)


# --- byte-level corruption of a valid file -------------------------------------------------

PRO_HEADER = ["time", "curL", "curR", "velL", "velR"]


def _pro_rows(n: int, rng) -> list[list[str]]:
    t = np.arange(n) * 0.1
    return [[f"{t[i]:.9g}", *(f"{x:.9g}" for x in rng.uniform(0.1, 0.8, 4))]
            for i in range(n)]


@FAST
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(8, 30),
       what=st.sampled_from(["truncate", "swap", "duplicate", "text", "burst"]),
       pick=st.integers(0, 10_000), cut=st.integers(0, 10_000))
def test_a_corrupted_file_is_a_named_error_or_a_counted_repair(tmp_path_factory, seed, n, what,
                                                               pick, cut):
    rng = np.random.default_rng(seed)
    rows = _pro_rows(n, rng)
    i = 1 + pick % (n - 2)                     # an inner data row
    j = 1 + cut % (len(PRO_HEADER) - 1)        # a channel column
    original = [list(r) for r in rows]
    if what == "truncate":                     # the line cut short, its line break kept
        line = ",".join(rows[i])
        rows[i] = line[:cut % len(line)].split(",")
    elif what == "swap":
        rows[i], rows[i + 1] = rows[i + 1], rows[i]
    elif what == "duplicate":
        rows.insert(i, list(rows[i]))
    elif what == "text":
        rows[i][j] = "1.2.3"
    elif what == "burst":
        for k in range(i, min(i + 3, n)):
            rows[k][j] = "nan"
    folder = tmp_path_factory.mktemp("bad") / "SNOW"
    folder.mkdir()
    path = folder / "pro_00.csv"
    _write(path, PRO_HEADER, rows)
    try:
        (run,) = _quiet_read(folder.parent)
    except DataFormatError as exc:
        assert exc.path == str(path) and exc.line is not None and str(path) in str(exc)
        expected = {"truncate": (RaggedRowError, NonFiniteError, NonNumericError),
                    "swap": TimestampError, "duplicate": TimestampError,
                    "text": NonNumericError, "burst": NonFiniteError}[what]
        assert isinstance(exc, expected)
        if not isinstance(exc, RaggedRowError):
            assert exc.column in PRO_HEADER
        if what in ("text", "burst"):
            assert exc.line == i + 2 and exc.column == PRO_HEADER[j]
        return
    # read: only a counted repair (a line cut after its last comma), a blank line (counted),
    # or a line cut inside its last number, a shorter number (not detectable in a file)
    assert what in ("truncate", "burst")
    wheels = run.streams["wheels"]
    if rows[i] == [""]:                       # the whole line cut: a blank line, counted
        assert run.meta["skipped_lines"] == {"wheels.blank": 1} and len(wheels) == n - 1
        return
    if run.meta["repaired"]:
        assert sum(run.meta["repaired"].values()) == (1 if what == "truncate" else
                                                      len(range(i, min(i + 3, n))))
    else:
        assert what == "truncate" and rows[i][:-1] == original[i][:-1]
        assert original[i][-1].startswith(rows[i][-1]) and rows[i][-1] != ""
    assert len(wheels) == n and np.isfinite(wheels.to_numpy(dtype=float)).all()


@pytest.mark.parametrize("native_hz, rate_hz, bound, beyond", [
    (100.0, 50.0, 1e-5, 0.0),        # the shipped case: the module's 1e-5 of the span
    (200.0, 10.0, 3e-3, 1e-3),       # the filter settles over more than its 15 samples of
    (1000.0, 6.5, 3e-2, 1e-2),       # padding: 0.2 % and 2.4 % of the span
])
def test_a_filtered_ramp_misses_its_ends_by_what_the_module_says(native_hz, rate_hz, bound,
                                                                 beyond):
    # the module said "a linear ramp's to 1e-5 of its span" for every filtered stream
    t = np.arange(int(3 * native_hz)) / native_hz
    frame = align_streams(make_run({"a": _stream(t, "x", 0.0, 1.0)}), ("a",), rate_hz=rate_hz)
    miss = np.abs(frame["x"].to_numpy() - frame[TIME].to_numpy()).max() / t[-1]
    assert beyond <= miss <= bound


@FAST
@given(n=st.integers(3, 30), text_rows=st.sets(st.integers(0, 29), min_size=1, max_size=29),
       cell=st.sampled_from(["abc", "1.2.3", "SNOW", "0x1F", "1e", "--1"]))
def test_an_extra_stream_channel_partly_text_is_refused_not_read_as_text(
        tmp_path_factory, n, text_rows, cell):
    # a channel of an extra stream is text only when every cell is (a per-sample label);
    # a number column with some text cells is a NonNumericError at the first, not a text
    # channel (the alignment would leave it out without a word)
    rows_ = sorted(r for r in text_rows if r < n)
    path = tmp_path_factory.mktemp("txt") / "truth_00.csv"
    rows = [[f"{0.1 * i:.9g}", cell if i in rows_ else f"{1.5 * i:.9g}"] for i in range(n)]
    _write(path, ["time", "v"], rows)
    if len(rows_) == n:
        frame, _ = read_stream_csv(path, "truth")
        assert list(frame["v"]) == [cell] * n
        return
    if not rows_:
        return
    with pytest.raises(NonNumericError) as info:
        read_stream_csv(path, "truth")
    err = info.value
    assert (err.path, err.column, err.line) == (str(path), "v", rows_[0] + 2)
