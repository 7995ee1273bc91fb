"""Terrain decisions of a trained classifier for the closed-loop simulation (helper of
``terrain control-sim``; not a subcommand: no add_arguments/main).

The classifier (``terrain train --model-out DIR``) is applied causally: the decision at time
t is the most recent window that *ended* by t (its class and probability); before the first
window ends there is no decision and the desired-slip table's fallback applies. The windows
are cut from the sensor streams of the uncontrolled run of the same seed (``terrain
simulate``'s batch sensor model, IMU vibration included): the controller changes the wheel
speeds slightly, not the terrain's vibration signature, and the online sensors of the loop
carry no vibration band. Applies where the model's classes include the run's terrain and the
model was trained on the vehicle's data: its shipped dataset (BorealTC: the Husky) or
simulated runs of the vehicle (metadata ``vehicle``, the live-sim classifier of
pipelines/control_classifier.py).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from terrain.serving.pyfunc import load_model, runs_to_model_input
from terrain.sim.simulate import SimConfig, simulate

#: Shipped dataset of each vehicle (the robot that recorded it).
VEHICLE_DATASET = {"husky": "borealtc"}


def classifier_decisions(model_dir: str, vehicle: str, terrain: str, scenario: str, seed: int,
                         duration_s: float, loaded: tuple | None = None
                         ) -> tuple[Callable[[float], tuple] | None, str, list[str]]:
    """A causal decision function from a trained model, or None with the reason.

    Parameters
    ----------
    model_dir : str
        MLflow model directory of ``terrain train``.
    vehicle, terrain, scenario : str
        The simulated run.
    seed : int
        Run seed.
    duration_s : float
        Simulated time, s.
    loaded : tuple, optional
        ``(model, metadata)`` of :func:`terrain.serving.pyfunc.load_model` for
        ``model_dir``, already loaded (a grid loads it once).

    Returns
    -------
    decide : callable or None
        ``decide(t_s) -> (label or None, confidence)``.
    note : str
        Where the decisions come from, or why the label is used instead.
    classes : list of str
        The model's classes.
    """
    model, meta = loaded or load_model(model_dir)
    classes = [str(c).upper() for c in meta.get("classes", [])]
    own_data = meta.get("vehicle") == vehicle or (
        vehicle in VEHICLE_DATASET and meta.get("dataset", VEHICLE_DATASET[vehicle])
        == VEHICLE_DATASET[vehicle])
    if not own_data or terrain not in classes:
        return None, (f"label: the model's classes {classes} do not include {terrain} or it was "
                      f"not trained on {vehicle} data, so the terrain comes from the label"),\
            classes
    run = simulate(SimConfig(vehicle=vehicle, terrains=(terrain,), scenario=scenario,
                             duration_s=duration_s, seed=seed))
    samples, _ = runs_to_model_input([run], meta["channels"], float(meta["rate_hz"]))
    pred = model.predict(samples)
    t_end = pred["t_end_s"].to_numpy(dtype=float)
    labels = pred["predicted"].astype(str).to_numpy()
    conf = pred[[c for c in pred.columns if c.startswith("proba_")]].max(axis=1).to_numpy()

    def decide(t_s: float) -> tuple:
        i = int(np.searchsorted(t_end, t_s, side="right")) - 1
        return (None, 0.0) if i < 0 else (labels[i], float(conf[i]))

    return decide, (f"live classifier {model_dir} on the uncontrolled run's streams, windows "
                    f"ending by t; {len(pred)} windows, classes {classes}"), classes
