"""Terrain decisions of a trained classifier on the closed loop's own samples (helper of
``terrain control-sim`` / ``control-grid``; not a subcommand: no add_arguments/main).

The classifier (``terrain train --model-out DIR``, or the live-sim classifier of
pipelines/control_classifier.py) runs in the project's streaming core,
:class:`terrain.serving.StreamService` (bounded ring buffers, the readers' sample rules,
alignment onto the model's clock with :mod:`terrain.io.align`, a window every hop, the
model's own features), fed at every control call with the samples the loop's sensors took
(:class:`terrain.sim.closed_loop.OnlineSensors`): the full IMU ``imu_full`` (terrain
vibration and gravity, the batch sensor model's IMU generated online) and the wheel stream
(motors 1 and 2 as ``vel_l = omega r``, ``vel_r`` and ``cur_l``, ``cur_r``: the batch
model's ``pro`` mapping). A window ``[t_end - window_s, t_end)`` is classified once every
stream has a sample at or after ``t_end`` (on the Husky's 6.5 Hz wheel stream up to 0.15 s
later). The decision at loop time t is the latest one the service emitted from the samples
taken by t: the class and probability of its window (no temporal smoothing, as the batch
predictions); before the first, none, and the desired-slip table's fallback applies.

Applies where the model's classes include the run's terrain and the model was trained on the
vehicle's data (:func:`terrain.serving.model.model_vehicle`: its metadata ``vehicle``, as
``terrain train`` and the live-sim classifier write it, else its shipped dataset's: BorealTC
and Vulpi were recorded by the Husky).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from terrain.control.desired_slip import build_slip_table
from terrain.errors import DataFormatError
from terrain.serving.model import StreamModel, model_vehicle
from terrain.serving.service import UNCLASSIFIED_FLAGS, StreamConfig, StreamService
from terrain.serving.smoothing import SmoothingConfig
from terrain.serving.targets import TableTargets
from terrain.sim.closed_loop import Observation
from terrain.vehicles import get_vehicle

#: Decisions kept for look-ups (bounded; 64 hops of 0.5 s = 32 s of history).
MAX_DECISIONS = 64


def decision_hop_s(model: StreamModel) -> float:
    """Time between the live classifier's decisions, s.

    The model's ``metadata["hop_s"]`` (else ``model.window.hop_s``) where it is a number
    (the live-sim classifier: 0.5 s).
    A ``terrain train`` model stores ``hop_s: null`` (its batch windows back to back, as
    :class:`features.windows.WindowConfig` reads None); a live decision period is a
    streaming setting, so null (or no ``hop_s``) takes the streaming service's default,
    :class:`terrain.serving.service.StreamConfig` ``hop_s`` (0.5 s, also ``terrain stream
    --hop-s``'s default): a decision every 0.5 s, as the README states for control-sim.

    Parameters
    ----------
    model : StreamModel
        The classifier with its directory's metadata.

    Returns
    -------
    float
        Hop, s (> 0).
    """
    hop = model.metadata.get("hop_s")
    if hop is None:
        hop = model.window.hop_s  # a model built in memory carries its hop there
    return float(StreamConfig().hop_s if hop is None else hop)


class LiveClassifier:
    """Causal terrain decisions of a trained model on the loop's own samples.

    The :class:`terrain.control.closed_loop.LiveTerrain` of the closed loop: ``update`` is
    called with every observation, ``__call__`` gives the decision available at a time.

    Parameters
    ----------
    model : StreamModel
        Fitted window classifier (:func:`terrain.serving.model.load_stream_model`).
    vehicle : str
        Simulated vehicle (wheel radius for the rim speeds).

    Attributes
    ----------
    service : StreamService
        The streaming core (hop :func:`decision_hop_s`; no smoothing).
    n_windows : int
        Windows classified so far.
    """

    def __init__(self, model: StreamModel, vehicle: str) -> None:
        config = StreamConfig(hop_s=decision_hop_s(model),
                              smoothing=SmoothingConfig(dwell_s=None))
        self.service = StreamService(model, TableTargets(model.classes), config)
        self.wheel_radius_m = get_vehicle(vehicle).wheel_radius_m
        self._decisions: deque = deque(maxlen=MAX_DECISIONS)
        self.n_windows = 0

    def update(self, obs: Observation) -> None:
        """Push the observation's IMU and wheel samples; keep the decisions they complete.

        Parameters
        ----------
        obs : Observation
            Samples since the previous call (``imu_full``; ``wheels`` and ``currents`` at the
            same times).

        Raises
        ------
        DataFormatError
            Wheel and current samples at different times (before any sample is pushed: the
            classifier is left as it was).
        """
        # checked before any sample is pushed: a refused observation leaves the service as
        # it was (its IMU samples pushed first, and the decisions they completed lost)
        if len(obs.wheels) and not np.array_equal(obs.wheels[:, 0], obs.currents[:, 0]):
            raise DataFormatError("wheel and current samples at different times",
                                  "closed-loop observation")
        out = []
        if len(obs.imu_full):
            out += self.service.push("imu", obs.imu_full[:, 0], obs.imu_full[:, 1:])
        if len(obs.wheels):
            values = np.column_stack([obs.wheels[:, 1:3] * self.wheel_radius_m,
                                      obs.currents[:, 1:3]])
            out += self.service.push("wheels", obs.wheels[:, 0], values)
        for d in out:
            # a window the service did not classify (a gap...) is no decision: without
            # smoothing the service keeps the last class there with uniform probabilities
            # (0.5 of two classes, which a table's min_confidence of 0.5 trusts)
            unclassified = not UNCLASSIFIED_FLAGS.isdisjoint(d.flags.split("|"))
            label = None if d.terrain is None or unclassified else str(d.terrain).upper()
            self._decisions.append((float(obs.t_s), label,
                                    0.0 if label is None else float(d.confidence)))
        self.n_windows += len(out)

    def __call__(self, t_s: float) -> tuple:
        """The latest decision emitted by ``t_s``.

        Parameters
        ----------
        t_s : float
            Loop time, s.

        Returns
        -------
        tuple
            ``(label, confidence, t_decided_s)``: the decision with the loop time at which it
            was emitted, s (the loop takes the decision's age from it, so a classifier that
            stops deciding leaves the table's fallback after ``max_decision_age_s``);
            ``(None, 0.0)`` before the first decision (or before the oldest one kept) and for
            a window the service did not classify.
        """
        for t_avail, label, conf in reversed(self._decisions):
            if t_avail <= t_s + 1e-9:
                return (None, 0.0) if label is None else (label, conf, t_avail)
        return None, 0.0


def classifier_applies(model: StreamModel, vehicle: str, terrain: str) -> tuple[bool, str]:
    """Whether a model may decide the terrain of a simulated run, and the reason.

    Parameters
    ----------
    model : StreamModel
        The classifier with its directory's metadata.
    vehicle, terrain : str
        The simulated run.

    Returns
    -------
    applies : bool
        True where the model was trained on the vehicle's data and knows ``terrain``.
    note : str
        Where the decisions come from, or why the label is used instead.
    """
    classes = [str(c).upper() for c in model.classes]
    own_data = model_vehicle(model.metadata) == vehicle
    if not own_data or terrain.upper() not in classes:
        return False, (f"label: the model's classes {classes} do not include {terrain} or it "
                       f"was not trained on {vehicle} data, so the terrain comes from the label")
    return True, (f"live classifier on the loop's own samples (streaming service, "
                  f"{model.window.window_s:g} s windows, a decision every "
                  f"{decision_hop_s(model):g} s, latest one emitted "
                  f"by t); classes {classes}")


def live_decisions(model: StreamModel, vehicle: str, terrain: str):
    """A fresh live classifier for one closed-loop run, or None with the reason.

    Parameters
    ----------
    model : StreamModel
        The classifier (loaded once, shared read-only by the runs).
    vehicle, terrain : str
        The simulated run.

    Returns
    -------
    live : LiveClassifier or None
        None where the model does not apply (:func:`classifier_applies`).
    table : SlipTable or None
        Desired-slip table over the model's classes (None with ``live``).
    note : str
        Where the decisions come from, or why the label is used instead.
    """
    ok, note = classifier_applies(model, vehicle, terrain)
    if not ok:
        return None, None, note
    return (LiveClassifier(model, vehicle),
            build_slip_table([str(c).upper() for c in model.classes]), note)
