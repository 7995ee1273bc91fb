"""The closed loop's live terrain classifier, trained on simulated runs of the same vehicle
(helper of ``terrain control-sim`` / ``control-grid``; not a subcommand).

A classifier trained on the measured BorealTC runs calls every simulated Husky window SNOW
(the simulator's sensor model does not reproduce the measured signatures:
docs/control_validation.md). The controller runs in the simulated world, so its classifier is
trained there, as a robot engineer would train it on the robot's own runs: simulated runs of
the vehicle on the given terrains and scenarios, on *classifier seeds* (default 2000-2002)
disjoint from the evaluation seeds and the gain-tuning seeds (1000, 1001). The robot's logged
runs include runs with the traction controller on, so by default (``controlled_runs``) every
terrain, scenario and seed gives two training runs: one uncontrolled (:func:`simulate`) and
one closed loop with the traction controller on
(:func:`terrain.control.closed_loop.run_closed_loop`, the grid's run: the label as the
terrain decision, the controller's gains, estimator and feed-forward of the runs it will
serve), whose windows come from the run's
logged streams (the batch sensor model, as the uncontrolled runs). Trained on uncontrolled
runs only, the classifier degraded under control (the slip the controller holds changes the
wheel-speed and current signatures): docs/control_validation.md. Windows from
:func:`features.windows.make_windows` (2 s, hop 0.5 s, 50 Hz, all IMU and wheel channels,
``all``: ``terrain train``'s default signal set on Vulpi and combined, not on BorealTC, where
it leaves out the forward wheel speeds); the SVM of :func:`terrain.models.registry.make_model`
(window features -> scaler -> RBF SVC with Platt probabilities); saved as the same MLflow
model directory as ``terrain train --model-out`` (:func:`terrain.serving.pyfunc.save_model`),
cached under ``out/control_classifier/<vehicle>-<key>/model`` (the key hashes the settings,
the controller of the closed-loop training runs (its full configuration with the gains, the
estimator, the feed-forward flag), the simulator's inputs that shape the training runs
(physics version, sensor settings, vehicle and terrain parameters, and the simulator's source
code: :func:`terrain.sim.digest.simulator_digest`) and the source of the modules that build
the model and drive the controlled runs (:data:`CLASSIFIER_MODULES`), so a cached model is
never reused after the code that made it changed), and applied by the same
causal decision path as ``--model``: a :class:`pipelines.live_terrain.LiveClassifier` per
closed-loop run, fed with the loop's own sensor samples.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shutil
import tempfile
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from features.windows import WindowConfig, make_windows
from pipelines.arguments import DistinctSeeds, seed_value
from terrain.control.closed_loop import LOOP_SETTINGS, default_gains, run_closed_loop
from terrain.control.estimators import ESTIMATORS
from terrain.control.grid import TUNING_SEEDS
from terrain.control.traction import config_for_vehicle
from terrain.errors import ConfigError, config_seed, duplicated
from terrain.io.jsonfile import replace_text
from terrain.models.registry import ModelConfig, make_model
from terrain.serving.model import load_stream_model, training_steps_s
from terrain.serving.pyfunc import runs_to_model_input, save_model
from terrain.sim.digest import simulator_digest, source_digest
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
#: Run-id suffix of the closed-loop training runs (the controller on).
CONTROLLED_SUFFIX = "+traction"
#: Modules besides the simulator's whose code shapes a cached classifier: this module
#: (which runs, windows and model it trains), the window features and models it is built
#: from, the MLflow model it is saved as, and the closed loop (controller and estimators)
#: that drives its controlled training runs.
CLASSIFIER_MODULES: tuple[str, ...] = ("pipelines.control_classifier", "features",
                                       "terrain.models", "terrain.serving",
                                       "terrain.control", "terrain.estimation")


def _controller_settings(vehicle: str, gains: tuple[float, float] | None,
                         estimator: str | None, feed_forward: bool) -> dict:
    """The controller of the closed-loop training runs, as the cache key sees it.

    Parameters
    ----------
    vehicle : str
        Simulated vehicle with a closed loop (:data:`terrain.control.estimators.ESTIMATORS`).
    gains : tuple of float or None
        ``(kp, ki)``; None: the tuned defaults of the vehicle and estimator.
    estimator : str or None
        Estimator kind; None: the vehicle's default.
    feed_forward : bool
        Feed-forward slip limit.

    Returns
    -------
    dict
        ``gains``, ``estimator`` (resolved), ``feed_forward`` and ``config`` (the ``repr`` of
        the controller's full :class:`terrain.control.traction.TractionControlConfig`).

    Raises
    ------
    ConfigError
        A vehicle without a closed loop, or an estimator that is not one of its own.
    """
    if vehicle not in ESTIMATORS or vehicle not in LOOP_SETTINGS:
        raise ConfigError(f"no closed loop for vehicle {vehicle!r} (controlled_runs=False "
                          "trains on uncontrolled runs only)")
    kind = estimator or ESTIMATORS[vehicle][0]
    if kind not in ESTIMATORS[vehicle]:
        raise ConfigError(f"estimator {kind!r} not available for {vehicle}; valid: "
                          f"{', '.join(ESTIMATORS[vehicle])}")
    kp, ki = gains or default_gains(vehicle, kind)
    cfg, _ = config_for_vehicle(vehicle, kp=float(kp), ki=float(ki), **LOOP_SETTINGS[vehicle])
    return {"gains": [float(kp), float(ki)], "estimator": kind,
            "feed_forward": bool(feed_forward), "config": repr(cfg)}


def sim_classifier(vehicle: str, terrains: Sequence[str],
                   seeds: Sequence[int] = CLASSIFIER_SEEDS,
                   scenarios: Sequence[str] = CLASSIFIER_SCENARIOS, signals: str = "all",
                   duration_s: float = 20.0, cache_dir: str | Path = "out/control_classifier",
                   reserved_seeds: Sequence[int] = (), controlled_runs: bool = True,
                   gains: tuple[float, float] | None = None, estimator: str | None = None,
                   feed_forward: bool = True) -> tuple[Path, dict]:
    """Train (or load from the cache) the SVM terrain classifier on simulated runs.

    Per terrain, scenario and seed: an uncontrolled run, and with ``controlled_runs`` a
    closed-loop run with the traction controller on
    (:func:`terrain.control.closed_loop.run_closed_loop`, the run of the control grid with
    the label as terrain decision); the windows of both come from the run's logged streams
    (the batch sensor model).

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
    controlled_runs : bool
        True (default): also train on closed-loop runs with the traction controller on, as a
        robot's logged runs include them; False: uncontrolled runs only (the earlier
        classifier, which degrades under control: docs/control_validation.md).
    gains : tuple of float, optional
        ``(kp, ki)`` of the controlled runs (rad/s per unit slip; rad/s per unit slip and
        s); None: :func:`terrain.control.closed_loop.default_gains` of the vehicle and
        estimator.
    estimator : str, optional
        Slip estimator of the controlled runs
        (:func:`terrain.control.estimators.estimator_for`); None: the vehicle's default.
    feed_forward : bool
        Feed-forward slip limit in the controlled runs.

    Returns
    -------
    model_dir : pathlib.Path
        MLflow model directory (``terrain train --model-out`` format; metadata ``vehicle``,
        ``dataset = sim``, ``seeds``, ``scenarios``, ``controlled_runs``,
        ``training_windows``, and ``channel_steps_s``, the training runs' sample step of
        each channel, :func:`terrain.serving.model.training_steps_s`, as ``terrain train``
        saves it).
    info : dict
        The settings (``controller``: the controlled runs' configuration, None without
        them), the training windows in all, per class and from controlled runs
        (``controlled_windows``), and the training accuracy.

    Raises
    ------
    ConfigError
        A training seed is an evaluation or tuning seed or not a whole number >= 0 (named
        ``seeds[i]``), no terrain / seed is given, a terrain (in any case), seed or scenario
        is given more than once, or (``controlled_runs``) the vehicle has no closed loop or
        the estimator is not one of its own; all before any training run.
    """
    for i, seed in enumerate(seeds):   # (int() trained 2000.5 as seed 2000)
        config_seed(f"sim_classifier seeds[{i}]", seed)
    check_classifier_seeds(seeds, reserved_seeds)
    if not terrains or not seeds or not scenarios:
        raise ConfigError("the classifier needs at least one terrain, seed and scenario")
    for axis, values in (("terrains", [str(t).upper() for t in terrains]),
                         ("seeds", [int(s) for s in seeds]), ("scenarios", list(scenarios))):
        repeated = duplicated(values)   # the same training runs twice, under one run id
        if repeated:
            raise ConfigError(f"sim_classifier {axis}: {repeated} given more than once (each "
                              "training run once)")
    settings = {"vehicle": vehicle, "terrains": sorted(str(t).upper() for t in terrains),
                "seeds": sorted(int(s) for s in seeds), "scenarios": list(scenarios),
                "signals": signals, "duration_s": float(duration_s),
                "window_s": CLASSIFIER_WINDOW.window_s, "hop_s": CLASSIFIER_WINDOW.hop_s,
                "rate_hz": CLASSIFIER_WINDOW.rate_hz, "model": "svm",
                "simulator": simulator_digest(vehicle, terrains),
                "code": source_digest(CLASSIFIER_MODULES),
                "controlled_runs": bool(controlled_runs),
                "controller": (_controller_settings(vehicle, gains, estimator, feed_forward)
                               if controlled_runs else None)}
    key = hashlib.sha1(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:10]
    folder = Path(cache_dir) / f"{vehicle}-{key}"
    model_dir, info_path = folder / "model", folder / "info.json"
    if (model_dir / "MLmodel").exists() and info_path.exists():
        return model_dir, {**json.loads(info_path.read_text()), "cached": True}
    ctrl = settings["controller"]
    runs = []
    for t in settings["terrains"]:
        for sc in scenarios:
            for s in settings["seeds"]:
                # one id per run (sim/<TERRAIN>/<scenario>/<seed>), as make_windows groups
                # and counts windows by run id
                run = simulate(SimConfig(vehicle=vehicle, terrains=(t,), scenario=sc,
                                         duration_s=duration_s, seed=s))
                runs.append(run)
                run_id = run.run_id
                if ctrl is not None:   # the robot's logged run with the controller on
                    run = run_closed_loop(vehicle, t, sc, True, s, duration_s,
                                          tuple(ctrl["gains"]), estimator=ctrl["estimator"],
                                          feed_forward=ctrl["feed_forward"])[0].run
                    runs.append(dataclasses.replace(
                        run, run_id=f"{run_id}{CONTROLLED_SUFFIX}",
                        meta={**run.meta, "controller": "traction"}))
    ws = make_windows(runs, signals, CLASSIFIER_WINDOW)
    y = ws.labels.astype(str)
    from_controlled = np.array([str(r).endswith(CONTROLLED_SUFFIX) for r in ws.run_ids],
                               dtype=bool)
    pipe = make_model(ModelConfig(kind="svm"), ws.channels, CLASSIFIER_WINDOW.rate_hz, "sim")
    pipe.fit(ws.X, y)
    classes = [str(c) for c in pipe.classes_]
    info = {**settings, "key": key, "training_windows": int(len(ws)),
            "controlled_windows": int(np.sum(from_controlled)),
            "windows_per_class": {c: int(np.sum(y == c)) for c in classes},
            "training_accuracy": float(np.mean(pipe.predict(ws.X) == y))}
    # a staging name of this training's own: two commands training the same entry at once
    # (two control-grid runs) each removed the other's half-written ``model.tmp``
    folder.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".model-", suffix=".partial", dir=folder)) / "model"
    try:
        example = runs_to_model_input(runs[:1], ws.channels, CLASSIFIER_WINDOW.rate_hz)[0]
        save_model(tmp, pipe, ws.channels, CLASSIFIER_WINDOW, classes,
                   {"dataset": "sim", "vehicle": vehicle, "seeds": settings["seeds"],
                    "scenarios": list(scenarios), "signals": signals,
                    "controlled_runs": bool(controlled_runs),
                    "training_windows": int(len(ws)),
                    # as terrain train's: a live stream's first steps are judged against
                    # the training runs' step of each channel
                    "channel_steps_s": training_steps_s(runs, ws.channels)},
                   input_example=example.head(CLASSIFIER_WINDOW.n_samples))
        _move_in(tmp, model_dir)
    finally:
        shutil.rmtree(tmp.parent, ignore_errors=True)
    # whole or not at all: the cache takes a model with its info.json as complete
    replace_text(info_path, json.dumps(info, indent=1) + "\n")
    return model_dir, {**info, "cached": False}


def _move_in(staged: Path, model_dir: Path) -> None:
    """Rename the staged model folder onto ``model_dir`` in one step.

    A whole model another command moved in meanwhile (the same settings, so the same
    training) is kept and ``staged`` left to be removed: the other command, or a third one
    that found the cache complete, may be reading it. Anything else in the way (a folder
    without ``MLmodel``) is removed first.
    """
    for _ in range(3):
        try:
            staged.rename(model_dir)
            return
        except OSError:
            if (model_dir / "MLmodel").exists():
                return
            if not model_dir.exists():
                raise
            shutil.rmtree(model_dir, ignore_errors=True)
    staged.rename(model_dir)


def add_classifier_options(parser) -> None:
    """Add the live-sim classifier's options, ``--classifier-seeds`` and
    ``--classifier-uncontrolled-only`` (``terrain control-sim``, ``terrain control-grid``).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    parser.add_argument("--classifier-seeds", nargs="+", type=seed_value, action=DistinctSeeds,
                        default=None,
                        help="training seeds of the live-sim classifier (default: "
                             f"{' '.join(map(str, CLASSIFIER_SEEDS))})")
    parser.add_argument("--classifier-uncontrolled-only", action="store_true",
                        help="train the live-sim classifier on uncontrolled runs only "
                             "(default: also on runs with the traction controller on)")


def check_classifier_seeds(seeds: Sequence[int], reserved_seeds: Sequence[int]) -> None:
    """Refuse live-sim classifier training seeds that are evaluation or tuning seeds.

    Parameters
    ----------
    seeds : sequence of int
        Training seeds of the classifier.
    reserved_seeds : sequence of int
        Seeds of the runs the classifier will serve (the evaluation seeds); the gain-tuning
        seeds (:data:`terrain.control.grid.TUNING_SEEDS`) are always reserved.

    Raises
    ------
    ConfigError
        A training seed is a reserved one (named).
    """
    shared = sorted(set(seeds) & (set(reserved_seeds) | set(TUNING_SEEDS)))
    if shared:
        raise ConfigError(f"classifier seeds {shared} are evaluation or tuning seeds")


def check_decision_options(source: str, model_dir: str | Path | None,
                           classifier_seeds: Sequence[int] | None,
                           uncontrolled_only: bool) -> None:
    """Refuse, before any run, options the chosen terrain source would ignore.

    Parameters
    ----------
    source : {"label", "live-sim", "model"}
        The terrain source (``--terrain-source``).
    model_dir : str or pathlib.Path or None
        ``--model``: used by ``model`` only.
    classifier_seeds : sequence of int or None
        ``--classifier-seeds`` as given (None: not given); used by ``live-sim`` only.
    uncontrolled_only : bool
        ``--classifier-uncontrolled-only``; used by ``live-sim`` only.

    Raises
    ------
    ConfigError
        ``--model`` with another source than ``model``, ``model`` without ``--model``, or a
        live-sim classifier option with another source than ``live-sim``.
    """
    if model_dir and source != "model":
        raise ConfigError(f"--model is used only with --terrain-source model, not "
                          f"{source!r}: leave one of them out")
    if source == "model" and not model_dir:
        raise ConfigError("--terrain-source model needs --model DIR")
    given = [name for name, on in (("--classifier-seeds", classifier_seeds is not None),
                                   ("--classifier-uncontrolled-only", uncontrolled_only))
             if on]
    if given and source != "live-sim":
        verb = "train" if len(given) > 1 else "trains"
        raise ConfigError(f"{' and '.join(given)} {verb} the live-sim classifier; "
                          f"--terrain-source {source} uses none: leave "
                          f"{'them' if len(given) > 1 else 'it'} out")


def decision_source(source: str, vehicle: str, terrains: Sequence[str],
                    eval_seeds: Sequence[int], model_dir: str | Path | None = None,
                    classifier_seeds: Sequence[int] = CLASSIFIER_SEEDS,
                    cache_dir: str | Path = "out/control_classifier",
                    controlled_runs: bool = True, gains: tuple[float, float] | None = None,
                    estimator: str | None = None, feed_forward: bool = True
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
    model_dir : str or pathlib.Path, optional
        Model directory for ``source = "model"``.
    classifier_seeds : sequence of int
        Training seeds of ``live-sim``.
    cache_dir : str or pathlib.Path
        Cache folder of ``live-sim`` models.
    controlled_runs : bool
        ``live-sim``: also train on closed-loop runs with the controller on (default; see
        :func:`sim_classifier`).
    gains : tuple of float, optional
        ``live-sim``: ``(kp, ki)`` of those runs (the gains of the loops it will serve);
        None: the vehicle's tuned defaults.
    estimator : str, optional
        ``live-sim``: slip estimator of those runs; None: the vehicle's default.
    feed_forward : bool
        ``live-sim``: feed-forward slip limit in those runs.

    Returns
    -------
    provider : callable or None
        ``provider(terrain) -> (live or None, table or None, note)``, to be called once per
        closed-loop run: a fresh :class:`pipelines.live_terrain.LiveClassifier` (fed with
        the run's own samples) and a desired-slip table over the model's classes, or None
        and the reason where the model does not apply; None for ``label``.
    info : dict
        ``terrain_source``, the model directory and, for ``live-sim``, the training info.

    Raises
    ------
    ConfigError
        Unknown source, ``model`` without ``model_dir``, classifier seeds that are
        evaluation or tuning seeds, a vehicle without a closed loop or a foreign estimator
        (``live-sim`` with ``controlled_runs``).
    """
    from pipelines.live_terrain import live_decisions

    if source not in TERRAIN_SOURCES:
        raise ConfigError(f"unknown terrain source {source!r}; valid: {list(TERRAIN_SOURCES)}")
    if source == "label":
        return None, {"terrain_source": "label"}
    info: dict = {"terrain_source": source}
    if source == "live-sim":
        terr = list(dict.fromkeys([*GRID_TERRAINS, *(t.upper() for t in terrains)]))
        path, train = sim_classifier(vehicle, terr, classifier_seeds, cache_dir=cache_dir,
                                     reserved_seeds=eval_seeds,
                                     controlled_runs=controlled_runs, gains=gains,
                                     estimator=estimator, feed_forward=feed_forward)
        info.update(model_dir=str(path), classifier=train)
    elif not model_dir:
        raise ConfigError("--terrain-source model needs --model DIR")
    else:
        path = Path(model_dir)
        info.update(model_dir=str(path))
    model = load_stream_model(path)

    def provider(terrain: str):
        return live_decisions(model, vehicle, terrain)

    return provider, info
