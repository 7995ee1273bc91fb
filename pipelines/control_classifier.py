"""The closed loop's live terrain classifier, trained on simulated runs of the same vehicle
(helper of ``terrain control-sim`` / ``control-grid``; not a subcommand).

A classifier trained on the measured BorealTC runs calls every simulated Husky window SNOW
(the simulator's sensor model does not reproduce the measured signatures:
docs/control_validation.md). The controller runs in the simulated world, so its classifier is
trained there, as a robot engineer would train it on the robot's own runs: simulated runs of
the vehicle on the given terrains and scenarios, on *classifier seeds* (default 2000-2002)
disjoint from the evaluation seeds and the gain-tuning seeds (1000, 1001); windows from
:func:`features.windows.make_windows` (2 s, hop 0.5 s, 50 Hz, all IMU and wheel channels:
``terrain train``'s default signal set); the SVM of :func:`terrain.models.registry.make_model`
(window features -> scaler -> RBF SVC with Platt probabilities); saved as the same MLflow
model directory as ``terrain train --model-out`` (:func:`terrain.serving.pyfunc.save_model`),
cached under ``out/control_classifier/<key>/model``, and applied by the same causal decision
path as ``--model`` (:func:`pipelines.live_terrain.classifier_decisions`).
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from features.windows import WindowConfig, make_windows
from terrain.control.desired_slip import build_slip_table
from terrain.control.grid import TUNING_SEEDS
from terrain.errors import ConfigError
from terrain.models.registry import ModelConfig, make_model
from terrain.serving.pyfunc import load_model, runs_to_model_input, save_model
from terrain.sim.simulate import SimConfig, simulate

#: Seeds of the classifier's training runs (disjoint from the evaluation and tuning seeds).
CLASSIFIER_SEEDS: tuple[int, ...] = (2000, 2001, 2002)
#: Scenarios of the training runs (every manoeuvre of the closed loop).
CLASSIFIER_SCENARIOS: tuple[str, ...] = ("straight_accel", "orchard", "slope_turn")
#: Terrains of the control grid (docs/control_validation.md).
GRID_TERRAINS: tuple[str, ...] = ("TILES", "GRASS", "UNPLOUGHED", "SANDY_LOAM", "SNOW", "ICE")
#: Windows of the classifier: 2 s (the project's window), a decision every 0.5 s, 50 Hz.
CLASSIFIER_WINDOW = WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=50.0)
TERRAIN_SOURCES = ("label", "live-sim", "model")


def sim_classifier(vehicle: str, terrains: Sequence[str],
                   seeds: Sequence[int] = CLASSIFIER_SEEDS,
                   scenarios: Sequence[str] = CLASSIFIER_SCENARIOS, signals: str = "all",
                   duration_s: float = 20.0, cache_dir: str | Path = "out/control_classifier",
                   reserved_seeds: Sequence[int] = ()) -> tuple[Path, dict]:
    """Train (or load from the cache) the SVM terrain classifier on simulated runs.

    Parameters
    ----------
    vehicle : str
        Simulated vehicle (``husky``, ``agrimaro``).
    terrains : sequence of str
        Catalogued terrain classes (one training run per terrain, scenario and seed).
    seeds : sequence of int
        Seeds of the training runs.
    scenarios : sequence of str
        Simulator scenarios of the training runs.
    signals : str
        Signal set of :func:`features.windows.resolve_signals` (``all``, ``imu``...).
    duration_s : float
        Simulated time per training run, s.
    cache_dir : str or pathlib.Path
        Folder of the cached model directories (one per setting, keyed by a hash of them).
    reserved_seeds : sequence of int
        Seeds the training must not use (evaluation seeds); the tuning seeds
        (:data:`terrain.control.grid.TUNING_SEEDS`) are always reserved.

    Returns
    -------
    model_dir : pathlib.Path
        MLflow model directory (``terrain train --model-out`` format; metadata ``vehicle``,
        ``dataset = sim``, ``seeds``, ``scenarios``, ``training_windows``).
    info : dict
        The settings, the training windows per class and the training accuracy.

    Raises
    ------
    ConfigError
        A training seed is an evaluation or tuning seed, or no terrain / seed is given.
    """
    shared = sorted(set(seeds) & (set(reserved_seeds) | set(TUNING_SEEDS)))
    if shared:
        raise ConfigError(f"classifier seeds {shared} are evaluation or tuning seeds")
    if not terrains or not seeds or not scenarios:
        raise ConfigError("the classifier needs at least one terrain, seed and scenario")
    settings = {"vehicle": vehicle, "terrains": sorted(str(t).upper() for t in terrains),
                "seeds": sorted(int(s) for s in seeds), "scenarios": list(scenarios),
                "signals": signals, "duration_s": float(duration_s),
                "window_s": CLASSIFIER_WINDOW.window_s, "hop_s": CLASSIFIER_WINDOW.hop_s,
                "rate_hz": CLASSIFIER_WINDOW.rate_hz, "model": "svm"}
    key = hashlib.sha1(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:10]
    folder = Path(cache_dir) / f"{vehicle}-{key}"
    model_dir, info_path = folder / "model", folder / "info.json"
    if (model_dir / "MLmodel").exists() and info_path.exists():
        return model_dir, {**json.loads(info_path.read_text()), "cached": True}
    runs = [simulate(SimConfig(vehicle=vehicle, terrains=(t,), scenario=sc,
                               duration_s=duration_s, seed=s))
            for t in settings["terrains"] for sc in scenarios for s in settings["seeds"]]
    ws = make_windows(runs, signals, CLASSIFIER_WINDOW)
    y = ws.labels.astype(str)
    pipe = make_model(ModelConfig(kind="svm"), ws.channels, CLASSIFIER_WINDOW.rate_hz, "sim")
    pipe.fit(ws.X, y)
    classes = [str(c) for c in pipe.classes_]
    info = {**settings, "key": key, "training_windows": int(len(ws)),
            "windows_per_class": {c: int(np.sum(y == c)) for c in classes},
            "training_accuracy": float(np.mean(pipe.predict(ws.X) == y))}
    tmp = folder / "model.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    example = runs_to_model_input(runs[:1], ws.channels, CLASSIFIER_WINDOW.rate_hz)[0]
    save_model(tmp, pipe, ws.channels, CLASSIFIER_WINDOW, classes,
               {"dataset": "sim", "vehicle": vehicle, "seeds": settings["seeds"],
                "scenarios": list(scenarios), "signals": signals,
                "training_windows": int(len(ws))},
               input_example=example.head(CLASSIFIER_WINDOW.n_samples))
    shutil.rmtree(model_dir, ignore_errors=True)
    tmp.rename(model_dir)
    info_path.write_text(json.dumps(info, indent=1) + "\n")
    return model_dir, {**info, "cached": False}


def decision_source(source: str, vehicle: str, terrains: Sequence[str],
                    eval_seeds: Sequence[int], duration_s: float,
                    model_dir: str | None = None,
                    classifier_seeds: Sequence[int] = CLASSIFIER_SEEDS,
                    cache_dir: str | Path = "out/control_classifier"
                    ) -> tuple[Callable | None, dict]:
    """Terrain decisions of one vehicle for the closed loop, per run.

    Parameters
    ----------
    source : {"label", "live-sim", "model"}
        ``label``: the run's ground-truth label (returns None); ``live-sim``: the classifier
        of :func:`sim_classifier` trained on ``classifier_seeds``; ``model``: the model
        directory ``model_dir`` of ``terrain train --model-out``.
    vehicle : str
        Simulated vehicle.
    terrains : sequence of str
        Terrains of the closed-loop runs (``live-sim``: trained on these and
        :data:`GRID_TERRAINS`).
    eval_seeds : sequence of int
        Seeds of the closed-loop runs (reserved from the classifier's training).
    duration_s : float
        Simulated time of each closed-loop run, s.
    model_dir : str, optional
        Model directory for ``source = "model"``.
    classifier_seeds : sequence of int
        Training seeds of ``live-sim``.
    cache_dir : str or pathlib.Path
        Cache folder of ``live-sim`` models.

    Returns
    -------
    provider : callable or None
        ``provider(terrain, scenario, seed) -> (decide or None, table or None, note)``:
        the causal decision function of :func:`pipelines.live_terrain.classifier_decisions`
        with a desired-slip table over the model's classes; None for ``label``.
    info : dict
        ``terrain_source``, the model directory and, for ``live-sim``, the training info.

    Raises
    ------
    ConfigError
        Unknown source, ``model`` without ``model_dir``, classifier seeds that are
        evaluation or tuning seeds.
    """
    from pipelines.live_terrain import classifier_decisions

    if source not in TERRAIN_SOURCES:
        raise ConfigError(f"unknown terrain source {source!r}; valid: {list(TERRAIN_SOURCES)}")
    if source == "label":
        return None, {"terrain_source": "label"}
    info: dict = {"terrain_source": source}
    if source == "live-sim":
        terr = list(dict.fromkeys([*GRID_TERRAINS, *(t.upper() for t in terrains)]))
        path, train = sim_classifier(vehicle, terr, classifier_seeds, cache_dir=cache_dir,
                                     reserved_seeds=eval_seeds)
        info.update(model_dir=str(path), classifier=train)
    elif not model_dir:
        raise ConfigError("--terrain-source model needs --model DIR")
    else:
        path = Path(model_dir)
        info.update(model_dir=str(path))
    loaded = load_model(path)

    def provider(terrain: str, scenario: str, seed: int):
        decide, note, classes = classifier_decisions(str(path), vehicle, terrain, scenario,
                                                     seed, duration_s, loaded=loaded)
        return decide, (build_slip_table(classes) if decide is not None else None), note

    return provider, info
