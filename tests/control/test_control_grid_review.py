"""Review tests of the gain tuning and the evaluation grid (terrain.control.grid)."""

import pytest

import terrain.control.grid as grid
from terrain.errors import ConfigError


def _fake_run(vehicle, terrain, scenario, on, seed, duration_s, gains=None, **kw):
    """Simulated-run stand-in: time to cruise 1 s + seed / 1000 off, 1.5 times that on."""
    t_off = 1.0 + seed / 1000.0
    return None, None, {"time_to_speed_s": t_off * (1.5 if on else 1.0), "slip_rmse": 0.05,
                        "steady_slip_within_0_02": 1.0}


@pytest.mark.parametrize("kwargs, match", [
    ({"kp_grid": []}, "kp_grid"),
    ({"ki_grid": []}, "ki_grid"),
    ({"terrains": []}, "terrains"),
    ({"seeds": ()}, "seeds"),
    ({"seeds": (1000, 1000)}, "seeds"),
    ({"kp_grid": [1.0, 1.0]}, "kp_grid"),
    ({"time_weight": float("nan")}, "time_weight"),
    ({"steady_weight": -0.5}, "steady_weight"),
    ({"time_weight": "0.5"}, "time_weight"),
    ({"seeds": (1000, 0.5)}, r"seeds\[1\] must be an integer >= 0"),
    ({"seeds": (True,)}, r"seeds\[0\] must be an integer >= 0"),
])
def test_tuning_refuses_settings_that_leave_no_or_a_skewed_choice(monkeypatch, kwargs, match):
    """An empty grid ended in pandas' KeyError 'cost', empty seeds or a NaN weight in
    'Encountered all NA values'; a repeated seed counted that run twice and a negative
    weight rewarded a slower start. Each is a ConfigError naming the setting, before any
    run."""
    calls = []
    monkeypatch.setattr(grid, "run_closed_loop",
                        lambda *a, **kw: calls.append(a) or _fake_run(*a, **kw))
    args = {"terrains": ["ICE"], "kp_grid": [1.0, 2.0], "ki_grid": [0.0], "seeds": (1000,)}
    args.update(kwargs)
    with pytest.raises(ConfigError, match=match):
        grid.tune_gains("husky", args.pop("terrains"), args.pop("kp_grid"),
                        args.pop("ki_grid"), **args)
    assert calls == []


def test_tuning_pairs_each_controlled_run_with_the_uncontrolled_run_of_its_seed(monkeypatch):
    """The time increase compares the runs of one seed: seed 1000 reaches cruise at 2.0 s
    off and 3.0 s on, seed 1001 at 2.001 s and 3.0015 s; +50 % each, whatever the seeds'
    order (a cell mixing seeds would give 3.0 / 2.001 - 1 or 3.0015 / 2.0 - 1)."""
    monkeypatch.setattr(grid, "run_closed_loop", _fake_run)
    for seeds in ((1000, 1001), (1001, 1000)):
        _, table = grid.tune_gains("husky", ["ICE"], [1.0], [0.0], seeds=seeds)
        assert table.loc[0, "time_increase"] == pytest.approx(0.5, abs=1e-12)


def test_a_candidate_whose_controller_is_never_enabled_is_charged_the_full_slip_cost(
        monkeypatch):
    """kp 1: the controlled run has no slip RMSE (never enabled) and counts 1.0, not 0
    (which would make the candidate that never acts the best); kp 2: RMSE 0.05."""
    def fake_run(vehicle, terrain, scenario, on, seed, duration_s, gains=None, **kw):
        rmse = None if on and gains[0] == 1.0 else 0.05
        return None, None, {"time_to_speed_s": 1.0, "slip_rmse": rmse,
                            "steady_slip_within_0_02": 1.0}

    monkeypatch.setattr(grid, "run_closed_loop", fake_run)
    best, table = grid.tune_gains("husky", ["ICE"], [1.0, 2.0], [0.0], seeds=(1000,))
    assert table.set_index("kp")["slip_rmse"].to_dict() == pytest.approx({1.0: 1.0, 2.0: 0.05})
    assert best == (2.0, 0.0)


def test_a_grid_run_whose_provider_gives_no_live_classifier_is_marked_label(monkeypatch):
    """A provider that returns no ``live`` leaves the run on its label, and the row says
    ``label`` (not ``classifier``); each run gets its own provider call, off and on, with
    its own classifier passed on."""
    got = []

    def fake_run(veh, ter, sc, on, seed, duration_s, gains, **kw):
        got.append(kw["live_terrain"])
        return None, None, {"peak_slip": 0.1}

    monkeypatch.setattr(grid, "run_closed_loop", fake_run)
    monkeypatch.setattr("terrain.control.closed_loop.trace_frame", lambda sim, loop: None)
    made = []

    def provider(ter):
        made.append(object() if ter == "ICE" else None)
        return made[-1], None, "live"

    results, _ = grid.run_grid(["husky"], ["ICE", "SNOW"], ["straight_accel"], [0],
                               {"husky": (2.0, 0.0)}, decisions={"husky": provider})
    assert results.set_index(["terrain", "controller"])["terrain_source"].to_dict() == {
        ("ICE", "off"): "classifier", ("ICE", "traction"): "classifier",
        ("SNOW", "off"): "label", ("SNOW", "traction"): "label"}
    assert got == made and got[0] is not got[1]


def test_a_run_whose_uncontrolled_twin_never_reaches_cruise_counts_a_full_increase(
        monkeypatch):
    """Off never reaches cruise (None): no ratio exists, the run counts 1 (documented), not
    0 (which would credit the candidate with no delay at all)."""
    def fake_run(vehicle, terrain, scenario, on, seed, duration_s, gains=None, **kw):
        return None, None, {"time_to_speed_s": 2.0 if on else None, "slip_rmse": 0.05,
                            "steady_slip_within_0_02": 1.0}

    monkeypatch.setattr(grid, "run_closed_loop", fake_run)
    _, table = grid.tune_gains("husky", ["ICE"], [1.0], [0.0], seeds=(1000,))
    assert table.loc[0, "time_increase"] == 1.0


def test_a_grid_vehicle_without_gains_is_refused_before_any_run(monkeypatch):
    """gains for the Husky only, vehicles Husky and AgriMaRo: Python's KeyError 'agrimaro'
    came after every Husky run had been simulated; now a ConfigError naming the vehicle,
    before the first run."""
    calls = []
    monkeypatch.setattr(grid, "run_closed_loop",
                        lambda *a, **kw: calls.append(a) or (None, None, {"peak_slip": 0.1}))
    monkeypatch.setattr("terrain.control.closed_loop.trace_frame", lambda sim, loop: None)
    with pytest.raises(ConfigError, match="agrimaro"):
        grid.run_grid(["husky", "agrimaro"], ["ICE"], ["straight_accel"], [0],
                      {"husky": (2.0, 0.0)})
    assert calls == []


def test_the_peak_slip_cut_is_the_share_of_the_uncontrolled_peak_removed():
    """Peak 0.4 off and 0.1 on, both seeds: a cut of 0.75 (not the 0.25 left)."""
    import pandas as pd

    rows = [{"vehicle": "husky", "terrain": "ICE", "scenario": "straight_accel", "seed": s,
             "controller": c, "peak_slip": 0.4 if c == "off" else 0.1,
             "energy_j_per_m": 100.0, "time_to_speed_s": 2.0, "slip_rmse": 0.1,
             "steady_slip_within_0_02": 1.0, "mean_speed_m_s": 0.5, "terrain_accuracy": 1.0}
            for s in (0, 1) for c in ("off", "traction")]
    row = grid.compare(pd.DataFrame(rows)).iloc[0]
    assert row["peak_slip_cut"] == pytest.approx(0.75)
    assert "| 0.400 -> 0.100 | 75 % |" in grid.markdown_table(grid.compare(pd.DataFrame(rows)))


def test_the_tuning_cost_weights_each_term_by_its_own_weight(monkeypatch):
    """cost = slip RMSE + time_weight x time increase + steady_weight x steady miss (module
    docstring): with RMSE 0.05, +50 % to cruise and a steady miss of 1 - 0.8 = 0.2, weights
    0.25 and 2.0 give 0.05 + 0.125 + 0.4 = 0.575 (the weights swapped: 0.05 + 1.0 + 0.05)."""
    def fake_run(vehicle, terrain, scenario, on, seed, duration_s, gains=None, **kw):
        return None, None, {"time_to_speed_s": 3.0 if on else 2.0, "slip_rmse": 0.05,
                            "steady_slip_within_0_02": 0.8}

    monkeypatch.setattr(grid, "run_closed_loop", fake_run)
    _, table = grid.tune_gains("husky", ["ICE"], [1.0], [0.0], seeds=(1000,),
                               time_weight=0.25, steady_weight=2.0)
    row = table.iloc[0]
    assert (row["time_increase"], row["steady_miss"]) == pytest.approx((0.5, 0.2))
    assert row["cost"] == pytest.approx(0.575, abs=1e-12)


def test_the_terrain_accuracy_is_the_controlled_runs_and_an_undefined_cut_reads_n_a():
    """terrain_accuracy_on is the mean over the controlled runs (0.8 and 1.0: 0.9), not the
    uncontrolled runs' (0.2); a cut with no defined value (no run moves: energy NaN) is
    written n/a in the Markdown table, not "nan %"."""
    import pandas as pd

    rows = [{"vehicle": "husky", "terrain": "ICE", "scenario": "straight_accel", "seed": s,
             "controller": c, "peak_slip": 0.4 if c == "off" else 0.2,
             "energy_j_per_m": float("nan"), "time_to_speed_s": 2.0, "slip_rmse": 0.1,
             "steady_slip_within_0_02": 1.0, "mean_speed_m_s": 0.5,
             "terrain_accuracy": 0.2 if c == "off" else 0.8 + 0.2 * s}
            for s in (0, 1) for c in ("off", "traction")]
    table = grid.compare(pd.DataFrame(rows))
    assert table.loc[0, "terrain_accuracy_on"] == pytest.approx(0.9)
    md = grid.markdown_table(table)
    assert "| n/a -> n/a (0 -> 0 of 2 runs) | n/a % |" in md and "nan" not in md
    assert md.rstrip().endswith("| 0.90 |")
