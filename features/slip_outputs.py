"""Window outputs of the slip models for the EKF's slip pseudo-measurement (issue 10 item 4).

The physics slip (:func:`terrain.slip.physics.physics_slip`, through the ``phys_*`` columns of
:func:`features.slip_features.slip_features`) and the learned slip
(:class:`terrain.slip.learned.SlipRegressor`) of every 2 s window of a run, handed to
:func:`terrain.slip.estimate.estimate_skid_steer_slip_run`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from features.slip_features import (SLIP_CHANNELS, SLIP_WINDOW, one_hot_probabilities,
                                    slip_features, slip_windows)
from features.windows import WindowSet
from terrain.io.align import interpolated_mean_count
from terrain.run import Run
from terrain.slip.physics import (PhysicsSlipSettings, physics_slip,
                                  pitch_std_from_accelerometer, run_pitch_prior)
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.vehicles import HuskyParams, TrackedParams, get_vehicle


def slip_model_outputs(run: Run, learned_model: Any | None = None,
                       physics_settings: PhysicsSlipSettings = PhysicsSlipSettings()
                       ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] | None:
    """Physics and (with a model) learned slip of each 2 s window of a skid-steer run.

    The terrain probabilities are those of a confident classifier on the run's terrain label
    (one-hot over the catalogue; the label of a simulated run is its true terrain).

    Parameters
    ----------
    run : Run
        Skid-steer run with ``wheels`` (``vel_l, vel_r`` m/s, ``cur_l, cur_r`` A) and ``imu``
        streams, terrain label in ``run.terrain``.
    learned_model : SlipRegressor or None
        Fitted model (``predict`` -> ``slip_1, slip_2, ...``) on the features of
        :func:`features.slip_features.slip_features`; it gets their table, whose columns it
        checks against those it was fitted on (``feature_names_in_``, when it has them).
    physics_settings : PhysicsSlipSettings
        Uncertainties of the physics slip of the pseudo-measurement (the learned model's
        ``phys_*`` features keep the defaults it was trained with). The pseudo-measurement's
        load uncertainty also uses the run's pitch prior
        (:func:`terrain.slip.physics.run_pitch_prior`), which the per-window features do not.

    Returns
    -------
    dict or None
        ``{"physics": (t_s, slip (k, 2), std (k, 2)), "physics_interval": (t_s, lower (k, 2),
        upper (k, 2)), "physics_current": ..., "physics_transient": ..., "learned": ...}``
        with ``t_s`` the window centres, s; ``physics_interval`` is the physics slip's interval
        (:class:`terrain.slip.physics.PhysicsSlip` ``lower``, ``upper``), whose centre
        replaces a full-slip (+-1) window-side in the pseudo-measurement
        (:func:`terrain.slip.estimate.estimate_skid_steer_slip_run`); ``physics_current`` is
        the physics slip with the current noise as its only uncertainty (efficiency and
        rolling-loss uncertainties 0): its std is the traction-coefficient noise over the
        slope of the terrain's traction-slip curve, which sets the steady slip drift of
        :data:`terrain.slip.estimate.BATCH_FUSION`; ``physics_transient``'s std is the slip
        change inside the window (the traction that changed beyond the current noise,
        ``cur_*__std`` through :func:`terrain.slip.physics.within_window_current_std`), which
        sets its transient slip drift; the ``physics`` std includes that change too. The
        learned std is the model's variance-calibrated one
        (:meth:`terrain.slip.learned.SlipRegressor.predict_std` with ``moment="variance"``;
        NaN for a model without a calibration). ``t_s`` is the time a window mean describes;
        the estimate is therefore not causal: a filter step uses up to half a window, 1 s, of
        later data. None when the run is not of a skid-steer vehicle (``agrimaro``), lacks
        currents or IMU, its terrain is not in the catalogue, or it is shorter than one window
        (:func:`missing_slip_inputs` says which).

    Raises
    ------
    ShapeError, MissingColumnError
        ``learned_model`` was fitted on another number of feature columns, or on other
        columns or in another order (:func:`terrain.slip.learned.feature_names_mismatch`).
    """

    ws, missing = _slip_windows(run)
    if missing is not None:
        return None
    vehicle = get_vehicle(run.vehicle)
    X = slip_features(ws, vehicle, one_hot_probabilities([str(run.terrain)] * len(ws),
                                                         TERRAIN_NAMES))
    cur = X[["cur_l__mean", "cur_r__mean"]].to_numpy(float)
    rim = X[["vel_l__mean", "vel_r__mean"]].to_numpy(float)
    acc = np.repeat(X[["vel_mean__slope"]].to_numpy(float), 2, axis=1) / \
        vehicle.contact_geometry().wheel_radius_m
    # the pseudo-measurement averages the run's own current samples (15 Hz on Vulpi's Husky,
    # 6.5 Hz on BorealTC's and the simulator's); the learned model's phys_* features keep the
    # simulator's rate they were trained with
    n_cur = interpolated_mean_count(ws.X.shape[-1], ws.rate_hz, run.rate_hz("wheels"))

    spread = X[["cur_l__std", "cur_r__std"]].to_numpy(float)
    pitch_std = pitch_std_from_accelerometer(ws.X[:, list(ws.channels).index("ax")])

    # the run's pitch (mean, spread beyond the window noise) for the load uncertainty
    prior = run_pitch_prior(X["pitch"].to_numpy(float), pitch_std)

    def physics(settings: PhysicsSlipSettings, within: np.ndarray | None = spread):
        # the inputs of the phys_* features, plus the run's pitch prior
        return physics_slip(vehicle, {str(run.terrain): 1.0}, cur, rim, X["pitch"].to_numpy(),
                            acc, n_averaged=n_cur, settings=settings,
                            current_within_std_a=within, pitch_std_rad=pitch_std,
                            pitch_prior=prior)

    res = physics(physics_settings)
    phys, phys_std = res.slip, res.std
    # current noise alone: the traction noise over the slope of the terrain's curve; and with
    # the traction that changed inside the window: their quadrature difference is the slip
    # change inside the window (the transient part of the slip drift of BATCH_FUSION)
    noise_only = replace(physics_settings, efficiency_rel_std=0.0, hysteresis_rel_std=0.0)
    current_only = physics(noise_only, None)
    with_change = physics(noise_only)
    change = np.sqrt(np.maximum(with_change.std ** 2 - current_only.std ** 2, 0.0))
    t_mid = 0.5 * (ws.t_start_s + ws.t_end_s).astype(float)
    out = {"physics": (t_mid, phys, phys_std),
           "physics_interval": (t_mid, res.lower, res.upper),
           "physics_current": (t_mid, current_only.slip, current_only.std),
           "physics_transient": (t_mid, with_change.slip, change)}
    if learned_model is not None:
        # the table, not its array: a model that kept its feature names checks them
        pred = np.asarray(learned_model.predict(X), dtype=float)[:, :2]
        # the filter needs the error variance: the variance-calibrated std (heavy tails in)
        std = (np.asarray(learned_model.predict_std(X, moment="variance"), dtype=float)
               if hasattr(learned_model, "predict_std") else np.full_like(pred, np.nan))
        out["learned"] = (t_mid, pred, std)
    return out


def missing_slip_inputs(run: Run) -> str | None:
    """Why :func:`slip_model_outputs` gives None for a run, or None when it gives outputs.

    Parameters
    ----------
    run : Run
        Skid-steer run.

    Returns
    -------
    str or None
        The first input the slip models lack, in words (not a skid-steer vehicle, no wheel
        stream, no motor currents, no IMU, a terrain outside the catalogue, no complete
        window of :data:`features.slip_features.SLIP_WINDOW`), for the user's note; None
        when every input is there.
    """
    return _slip_windows(run)[1]


def _slip_windows(run: Run) -> tuple[WindowSet | None, str | None]:
    # the slip windows of the run, or the first missing input in words
    if not isinstance(get_vehicle(run.vehicle), (HuskyParams, TrackedParams)):
        # (the AgriMaRo's wheels stream holds wheels 1 and 2, no left and right side, and
        # its parameters no track: the features ended in a bare AttributeError)
        return None, f"not a skid-steer vehicle ({run.vehicle}: no left and right side)"
    w = run.streams.get("wheels")
    if w is None:
        return None, "no wheel stream"
    if not {"cur_l", "cur_r"} <= set(w.columns):
        return None, "no motor currents (cur_l, cur_r)"
    if "imu" not in run.streams:
        return None, "no IMU stream"
    if str(run.terrain) not in TERRAIN_NAMES:
        return None, f"terrain {str(run.terrain)!r} not in the terrain catalogue"
    ws = slip_windows([run])
    if len(ws) == 0 or set(SLIP_CHANNELS) - set(ws.channels):
        return None, (f"no complete {SLIP_WINDOW.window_s:g} s window of IMU and wheel "
                      "samples (run too short or gappy)")
    return ws, None


__all__ = ["missing_slip_inputs", "slip_model_outputs"]
