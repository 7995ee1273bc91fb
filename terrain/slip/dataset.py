"""Simulated Husky runs with truth for the slip models, cached on disk.

A :class:`SlipDataSpec` names a grid terrains x scenarios x seeds; :func:`simulated_runs`
simulates each cell once (:func:`terrain.sim.simulate.simulate`) and keeps the
:class:`~terrain.run.Run` in a cache folder (joblib files keyed by every setting of the run
and by :func:`terrain.sim.digest.simulator_digest`, which covers the simulator's parameters
and source code), so repeated ``terrain slip-fit`` calls on the shared machine cost no
simulation, and a run simulated before a change of the simulator is never reused.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import joblib

from terrain.errors import ConfigError, config_integer, config_numbers, duplicated
from terrain.run import Run
from terrain.sim.digest import simulator_digest
from terrain.sim.scenarios import SCENARIO_NAMES
from terrain.sim.simulate import SimConfig, simulate
from terrain.terramechanics.catalogue import TERRAIN_NAMES


@dataclass(frozen=True)
class SlipDataSpec:
    """Grid of simulated runs.

    Parameters
    ----------
    terrains : tuple of str
        Catalogue terrains (one terrain per run).
    scenarios : tuple of str
        Scenarios (:data:`terrain.sim.scenarios.SCENARIO_NAMES`).
    seeds : tuple of int
        Seeds (each seed gives other sensor noise and, for ``random``, other commands).
    duration_s : float
        Length of each run, s.
    vehicle : str
        Simulated vehicle.

    Raises
    ------
    ConfigError
        Unknown terrain or scenario, a value repeated on an axis, empty grid, a seed that is
        not an integer >= 0, a duration that is not a number or not > 0.
    """

    terrains: tuple[str, ...] = TERRAIN_NAMES
    scenarios: tuple[str, ...] = ("straight_accel", "orchard", "slope_turn", "random")
    seeds: tuple[int, ...] = (0, 1, 2)
    duration_s: float = 40.0
    vehicle: str = "husky"

    def __post_init__(self) -> None:
        for axis in ("terrains", "scenarios", "seeds"):     # the caller's list, frozen
            values = getattr(self, axis)
            # (a list appended to after the checks gave runs never checked)
            if isinstance(values, list) or hasattr(values, "tolist"):   # (an array too)
                object.__setattr__(self, axis, tuple(
                    values.tolist() if hasattr(values, "tolist") else values))
        bad = [t for t in self.terrains if t not in TERRAIN_NAMES]
        bad += [s for s in self.scenarios if s not in SCENARIO_NAMES]
        if bad:
            raise ConfigError(f"unknown terrains/scenarios {bad}; valid terrains "
                              f"{list(TERRAIN_NAMES)}, scenarios {list(SCENARIO_NAMES)}")
        if not (self.terrains and self.scenarios and self.seeds):
            raise ConfigError("the run grid is empty")
        for seed in self.seeds:     # configs() takes int(): 1.7 would be simulated as seed 1
            config_integer("SlipDataSpec.seeds", seed, 0)
        config_numbers("SlipDataSpec", duration_s=self.duration_s)
        for axis in ("terrains", "scenarios", "seeds"):
            repeated = duplicated(getattr(self, axis))
            if repeated:  # a run simulated and counted twice
                raise ConfigError(f"{axis}: {repeated} given more than once (each value of "
                                  "the run grid once)")
        if not self.duration_s > 0:
            raise ConfigError(f"duration_s must be > 0, got {self.duration_s}")

    def configs(self) -> Iterator[SimConfig]:
        """Simulation settings of every cell of the grid.

        Yields
        ------
        SimConfig
            One per ``(terrain, scenario, seed)``, terrains outermost and seeds innermost,
            each with a single terrain, this spec's ``vehicle`` and ``duration_s`` (s).
        """
        for terrain in self.terrains:
            for scenario in self.scenarios:
                for seed in self.seeds:
                    yield SimConfig(vehicle=self.vehicle, terrains=(terrain,),
                                    scenario=scenario, duration_s=float(self.duration_s),
                                    seed=int(seed))


def _cell(config: SimConfig) -> str:
    """Readable name of a run's cell plus a digest of all its settings (``repr``)."""
    settings = hashlib.sha1(repr(config).encode()).hexdigest()[:8]
    return (f"{config.vehicle}_{config.terrains[0]}_{config.scenario}_s{config.seed}_"
            f"{config.duration_s:g}s_{settings}")


def cache_key(config: SimConfig) -> str:
    """File name of a simulated run in the cache.

    Parameters
    ----------
    config : SimConfig
        One run's settings.

    Returns
    -------
    str
        ``<vehicle>_<TERRAIN>_<scenario>_s<seed>_<duration>s_<settings>_<simulator>.joblib``:
        ``settings`` (8 hex characters) hashes every field of ``config`` (its ``repr``),
        ``simulator`` is :func:`terrain.sim.digest.simulator_digest` of its vehicle and
        terrains (parameters and source code), so another setting, parameter or simulator
        source gives another file.

    Raises
    ------
    ConfigError
        Unknown vehicle or terrain.
    """
    return f"{_cell(config)}_{simulator_digest(config.vehicle, config.terrains)}.joblib"


def simulated_run(config: SimConfig, cache_dir: str | Path | None = None) -> Run:
    """One simulated run, from the cache when present.

    The run id is made unique across scenarios: ``sim/<TERRAIN>/<scenario>/<seed>``, and
    ``meta["scenario"]`` says the scenario.

    Parameters
    ----------
    config : SimConfig
        One terrain, default effects and sensors.
    cache_dir : str or Path, optional
        Cache folder (created); None = no cache. A run of the same settings cached by an
        earlier simulator (another :func:`terrain.sim.digest.simulator_digest`) is replaced,
        so the folder holds one file per cell and settings. Each write goes through a
        temporary file of its own, renamed into place: processes sharing the folder never
        read a partial file nor trip over each other's.

    Returns
    -------
    Run
    """
    path = None if cache_dir is None else Path(cache_dir) / cache_key(config)
    if path is not None and path.exists():
        return joblib.load(path)
    run = simulate(config)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        # a temporary file of this write's own: two processes filling one cell at once each
        # rename a whole file into place (one shared "<key>.tmp" was renamed away under the
        # other writer, whose own rename then failed with FileNotFoundError)
        handle, name = tempfile.mkstemp(prefix=path.stem + ".", suffix=".tmp", dir=path.parent)
        os.close(handle)
        tmp = Path(name)
        try:
            joblib.dump(run, tmp)
            tmp.replace(path)
        finally:
            tmp.unlink(missing_ok=True)
        for stale in path.parent.glob(f"{_cell(config)}_*.joblib"):
            if stale != path:   # the same run from an earlier simulator
                stale.unlink()
    return run


def simulated_runs(spec: SlipDataSpec, cache_dir: str | Path | None = None,
                   progress: bool = False) -> list[Run]:
    """Every run of the grid (simulated once, then read from the cache).

    Parameters
    ----------
    spec : SlipDataSpec
        The grid.
    cache_dir : str or Path, optional
        Cache folder; None = simulate everything in memory.
    progress : bool
        Show a progress bar (tqdm).

    Returns
    -------
    list of Run
    """
    configs = list(spec.configs())
    if progress:
        from tqdm.auto import tqdm
        configs = tqdm(configs, desc="simulating runs", unit="run")
    return [simulated_run(c, cache_dir) for c in configs]
