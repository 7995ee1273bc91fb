"""Properties of the held-out stream evaluation (:mod:`terrain.serving.evaluation`) against
brute-force references: how streams are strung together, the truth at a time, switching
delays, per-stream scores, pooled scores and the score table's round trip."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import DataFormatError
from terrain.run import Run
from terrain.serving.evaluation import (Segment, concatenated_streams, encode_stream_scores,
                                        pool_scores, read_stream_scores, score_stream,
                                        seed_accuracies, switching_delays, truth_at)

TERRAINS = ("ICE", "SNOW", "ASPHALT")


def _run(i: int, terrain: str, length_s: float, step_s: float, t0_s: float) -> Run:
    """A wheel run whose ``vel_l`` is its index, so a stream sample names its source run."""
    t = t0_s + np.arange(0.0, length_s, step_s)
    frame = pd.DataFrame({"t_s": t, "vel_l": float(i), "vel_r": 0.5, "cur_l": 1.0,
                          "cur_r": 1.0})
    return Run(f"syn/{terrain}/{i:02d}", "syn", terrain, {"wheels": frame})


@st.composite
def _runs(draw):
    n = draw(st.integers(2, 7))
    terrains = draw(st.lists(st.sampled_from(TERRAINS), min_size=n, max_size=n)
                    .filter(lambda ts: len(set(ts)) >= 2))
    runs = []
    for i, terrain in enumerate(terrains):
        length = draw(st.sampled_from([4.0, 9.5, 12.3, 35.0, 80.0]))
        step = draw(st.sampled_from([0.01, 0.1, 0.15384615384615385, 0.2]))
        t0 = draw(st.sampled_from([0.0, 3.7, 1.7e9 + 0.123]))
        runs.append(_run(i, terrain, length, step, t0))
    return runs


def _span(run: Run) -> float:
    t = run.streams["wheels"]["t_s"]
    return float(t.iloc[-1] - t.iloc[0])


def _fewest_joins(terrains) -> int:
    """Fewest neighbours of one terrain any order of these pieces has."""
    terrains = list(terrains)
    counts = pd.Series(terrains).value_counts()
    return max(0, 2 * int(counts.max()) - len(terrains) - 1) if len(counts) else 0


@settings(max_examples=40, deadline=None)
@given(runs=_runs(), seed=st.integers(0, 2**32 - 1),
       min_s=st.sampled_from([5.0, 20.0, 30.0]), extra_s=st.sampled_from([0.0, 10.0, 90.0]),
       gap_s=st.sampled_from([0.0, 0.1, 2.0]))
def test_a_concatenated_stream_is_seeded_uses_each_run_once_and_never_overlaps(
        runs, seed, min_s, extra_s, gap_s):
    shortest = min(min_s, 10.0)
    if len({r.terrain for r in runs if _span(r) >= shortest}) < 2:
        return      # the typed error (tests/serving/test_stream_construction.py)
    stream, segments = concatenated_streams(runs, ("wheels",), seed, min_s, min_s + extra_s,
                                            gap_s)
    again, segments2 = concatenated_streams(runs, ("wheels",), seed, min_s, min_s + extra_s,
                                            gap_s)
    assert segments2 == segments
    pd.testing.assert_frame_equal(again.streams["wheels"], stream.streams["wheels"])
    # every run used once, or named skipped: exactly those too short for a piece
    used = [s.run_id for s in segments]
    skipped = stream.meta["skipped_runs"]
    assert len(set(used)) == len(used)
    assert sorted(used + skipped) == sorted(r.run_id for r in runs)
    assert sorted(skipped) == sorted(r.run_id for r in runs if _span(r) < shortest)
    by_id = {r.run_id: r for r in runs}
    clock = 0.0
    for s in segments:
        run = by_id[s.run_id]
        t = run.streams["wheels"]["t_s"]
        assert s.terrain == run.terrain
        assert shortest <= s.duration_s <= min_s + extra_s
        # the piece lies in its run and starts where the stream clock stands
        assert t.iloc[0] <= s.t_from_s and s.t_from_s + s.duration_s <= t.iloc[-1] + 1e-9
        assert math.isclose(s.t_from_s + s.t_offset_s, clock, abs_tol=1e-6)
        clock += s.duration_s + gap_s
    # the stream's clock strictly increases and every sample lies in the piece of its run
    frame = stream.streams["wheels"]
    assert (np.diff(frame["t_s"].to_numpy()) > 0).all()
    truth = truth_at(segments, frame["t_s"].to_numpy())
    source = [runs[int(i)].terrain for i in frame["vel_l"]]
    assert list(truth) == source
    # the terrain changes at every switch wherever the pieces' terrains allow it
    joins = sum(a.terrain == b.terrain for a, b in zip(segments[:-1], segments[1:]))
    assert joins == _fewest_joins(s.terrain for s in segments)


@st.composite
def _segments(draw):
    n = draw(st.integers(1, 6))
    terrains = draw(st.lists(st.sampled_from(TERRAINS), min_size=n, max_size=n))
    durations = draw(st.lists(st.sampled_from([0.5, 1.0, 2.5, 4.0]), min_size=n, max_size=n))
    gap = draw(st.sampled_from([0.0, 0.5]))
    segments, clock = [], 0.0
    for i, (terrain, d) in enumerate(zip(terrains, durations)):
        start = draw(st.sampled_from([0.0, 7.25, 100.0]))
        segments.append(Segment(f"r{i}", terrain, start, clock - start, d))
        clock += d + gap
    return segments, clock


def _truth_ref(segments, t):
    out = []
    for x in t:
        hit = [s.terrain for s in segments
               if s.t_from_s + s.t_offset_s <= x < s.t_from_s + s.t_offset_s + s.duration_s]
        assert len(hit) <= 1
        out.append(hit[0] if hit else None)
    return out


def _delays_ref(segments, t, decided):
    """First decision naming the new terrain from each switch up to the end of the run of
    pieces of that terrain (inf when none)."""
    delays = []
    for i in range(1, len(segments)):
        new = segments[i].terrain
        if new == segments[i - 1].terrain:
            continue
        a = segments[i].t_from_s + segments[i].t_offset_s
        j = i
        while j + 1 < len(segments) and segments[j + 1].terrain == new:
            j += 1
        pieces = segments[i:j + 1]
        found = math.inf
        for x, d in zip(t, decided):
            inside = any(p.t_from_s + p.t_offset_s <= x < p.t_from_s + p.t_offset_s
                         + p.duration_s for p in pieces)
            if inside and d == new:
                found = x - a
                break
        delays.append(found)
    return delays


@st.composite
def _decisions(draw):
    segments, end = draw(_segments())
    n = draw(st.integers(0, 40))
    step = draw(st.sampled_from([0.25, 0.5, 0.3]))
    t0 = draw(st.sampled_from([-0.5, 0.0, 0.1]))
    t = t0 + step * np.arange(n)
    decided = np.array(draw(st.lists(st.sampled_from(TERRAINS + (None,)), min_size=n,
                                     max_size=n)), dtype=object)
    return segments, t, decided


@settings(max_examples=150, deadline=None)
@given(case=_decisions())
def test_truth_and_delays_equal_a_sample_by_sample_reference(case):
    segments, t, decided = case
    assert list(truth_at(segments, t)) == _truth_ref(segments, t)
    got = switching_delays(segments, t, decided)
    ref = _delays_ref(segments, t, decided)
    assert len(got) == len(ref)
    assert np.allclose(got, ref, atol=1e-9) and (np.isinf(got) == np.isinf(ref)).all()


@settings(max_examples=150, deadline=None)
@given(case=_decisions(), window_s=st.sampled_from([0.0, 0.4, 1.0, 3.0]))
def test_a_stream_score_is_a_direct_count_of_its_decisions(case, window_s):
    segments, t, decided = case
    score = score_stream(segments, t, decided, window_s)
    truth = _truth_ref(segments, t)
    back = _truth_ref(segments, t - window_s)
    scored = [(x, d) for x, d in zip(truth, decided) if x is not None]
    settled = [(x, d) for x, d, b in zip(truth, decided, back) if x is not None and b == x]
    assert score.n_decisions == len(scored)
    assert score.n_settled == len(settled)
    if scored:
        assert score.accuracy == sum(x == d for x, d in scored) / len(scored)
    else:
        assert math.isnan(score.accuracy)
    if settled:
        assert score.accuracy_settled == sum(x == d for x, d in settled) / len(settled)
    else:
        assert math.isnan(score.accuracy_settled)
    confusion: dict = {}
    for x, d in scored:
        key = "none" if d is None else d
        confusion.setdefault(x, {}).setdefault(key, 0)
        confusion[x][key] += 1
    assert score.confusion == confusion
    assert list(score.delays_s) == list(switching_delays(segments, t, decided))


@st.composite
def _score_rows(draw):
    rows = []
    for _ in range(draw(st.integers(1, 6))):
        n = draw(st.integers(0, 50))
        k = draw(st.integers(0, n))
        m = draw(st.integers(0, n))
        j = draw(st.integers(0, m))
        delays = draw(st.lists(st.sampled_from([0.0, 0.5, 1.25, 7.0, math.inf]), max_size=4))
        conf = {"ICE": {"ICE": k, "none": n - k}} if n else {}
        rows.append({"seed": draw(st.integers(0, 2)), "fold": len(rows), "smoothing": "raw",
                     "accuracy": k / n if n else math.nan,
                     "median_delay_s": float(np.median(delays)) if delays else math.nan,
                     "n_switches": len(delays), "n_decisions": n,
                     "accuracy_settled": j / m if m else math.nan, "n_settled": m,
                     "delays_s": delays, "confusion": conf})
    return pd.DataFrame(rows)


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(rows=_score_rows())
def test_pooled_scores_weigh_by_decisions_and_survive_the_csv(rows, tmp_path_factory):
    pooled = pool_scores(rows)
    n, m = rows["n_decisions"].sum(), rows["n_settled"].sum()
    right = sum(c["ICE"]["ICE"] for c in rows["confusion"] if c)
    if n:
        assert math.isclose(pooled["accuracy"], right / n)
        assert math.isclose(pooled["recall"]["ICE"], right / n)
    else:
        assert math.isnan(pooled["accuracy"])
    settled_right = (rows["accuracy_settled"].fillna(0) * rows["n_settled"]).sum()
    assert (math.isclose(pooled["accuracy_settled"], settled_right / m) if m
            else math.isnan(pooled["accuracy_settled"]))
    delays = [d for ds in rows["delays_s"] for d in ds]
    assert pooled["n_switches"] == len(delays)
    assert (pooled["median_delay_s"] == float(np.median(delays)) if delays
            else math.isnan(pooled["median_delay_s"]))
    for seed, acc in seed_accuracies(rows).items():
        g = rows[rows["seed"] == seed]
        ok = sum(c["ICE"]["ICE"] for c in g["confusion"] if c)
        assert math.isclose(acc, ok / g["n_decisions"].sum()) if g["n_decisions"].sum() \
            else math.isnan(acc)
    # writing then reading the table gives the same rows and the same pool
    path = tmp_path_factory.mktemp("scores") / "held_out_streams_wheels.csv"
    encode_stream_scores(rows).to_csv(path, index=False)
    back = read_stream_scores(path)
    assert list(back["delays_s"]) == list(rows["delays_s"])
    assert list(back["confusion"]) == list(rows["confusion"])
    pd.testing.assert_frame_equal(back.drop(columns=["delays_s", "confusion"]),
                                  rows.drop(columns=["delays_s", "confusion"]),
                                  check_dtype=False)
    again = pool_scores(back)
    for key in ("accuracy", "accuracy_settled", "median_delay_s"):
        assert again[key] == pooled[key] or (math.isnan(again[key]) and math.isnan(pooled[key]))
    assert again["confusion"] == pooled["confusion"]


def test_a_switch_not_followed_in_its_piece_is_not_followed_by_a_later_piece_of_its_terrain():
    # ICE, SNOW, ICE, SNOW: the switch onto the first SNOW piece is never followed (no SNOW
    # decision in it); the SNOW decided in the second SNOW piece follows the later switch
    # only, after an ICE piece in between (the robot left SNOW)
    segments = [Segment("a", "ICE", 0.0, 0.0, 2.0), Segment("b", "SNOW", 0.0, 2.0, 2.0),
                Segment("c", "ICE", 0.0, 4.0, 2.0), Segment("d", "SNOW", 0.0, 6.0, 2.0)]
    t = np.arange(0.25, 8.0, 0.5)
    decided = np.array(["ICE"] * 12 + ["SNOW"] * 4, dtype=object)
    delays = switching_delays(segments, t, decided)
    assert delays.tolist() == [math.inf, 0.25, 0.25]
    assert delays.tolist() == _delays_ref(segments, t, decided)


def test_a_delay_cell_with_something_else_than_numbers_is_refused_not_shortened(tmp_path):
    # "[1.5, oops, 2.0]" was read as [1.5, 2.0]: a switch dropped without a word (and the
    # pooled median and switch count changed with it)
    for bad in ("[1.5, oops, 2.0]", "[nan, 3.0]", "[1.5, , 2.0]"):
        path = tmp_path / "scores.csv"
        pd.DataFrame({"delays_s": ["[0.5, inf]", bad]}).to_csv(path, index=False)
        with pytest.raises(DataFormatError, match=r"delays_s.*line 3"):
            read_stream_scores(path)


@pytest.mark.parametrize("bad", ['{"ICE": 5}', '{"ICE": {"ICE": "x"}}',
                                 '{"ICE": {"ICE": -3, "SNOW": 3}}', '{"ICE": {"ICE": 1.5}}'])
def test_a_confusion_cell_without_counts_is_refused_where_it_is_read(tmp_path, bad):
    # such a mapping was read, then pool_scores failed with a bare AttributeError ('int'
    # object has no attribute 'items'), ValueError or ZeroDivisionError naming no file
    path = tmp_path / "scores.csv"
    frame = pd.DataFrame({"accuracy": [0.5, 0.5], "n_decisions": [4, 4],
                          "delays_s": ["[1.0]"] * 2,
                          "confusion": ['{"ICE": {"ICE": 2, "none": 2}}', bad]})
    frame.to_csv(path, index=False)
    with pytest.raises(DataFormatError, match=r"confusion.*line 3"):
        read_stream_scores(path)
