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
