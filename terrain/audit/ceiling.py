"""How much of the replay error any model of a given family could remove: the ceiling.

The audit's physics targets ask a simulator with **one parameter set per terrain** to cut the
replay error of measured runs by a given fraction. When a target is missed, this module
measures whether it is reachable at all by such a model, from the measured runs alone:

* **Yaw rate, steady kinematics.** The family ``wz = x / chi_m``: one ICR expansion factor
  per manoeuvre ``m`` (straight, curve, spin; :mod:`terrain.audit.frames`), the steady-state
  description of skid-steer turning (Mandow et al., IROS 2007; seed
  ``000_f24201ff985633bf.txt`` eqs. 2-3). Its best member is fitted by least squares **on the
  evaluated runs themselves** (``shared``): more generous than any parameter set chosen on
  other runs, so a cut it cannot reach is out of reach of every model of that family.
  Fitted per run as well (``per_run``: one ``chi_m`` for each run): the error left when the
  ground state of every run is known. The difference between the two is what varies between
  runs of one terrain and is not in the inputs.
  Fitted on *other* runs of the terrain and applied to the evaluated ones (``trained``, when
  training runs are given): what the family's parameter set gives on unseen runs when it is
  chosen as the targets' own parameters are, on training runs. The ``shared`` fit bounds it
  from above on the evaluated samples (least squares on them is the smallest error of the
  family there).
* **Motor current, recalibrated physics.** Per drive side, the measured current is fitted as
  an affine function of the physics' own prediction(s) (the reference replay and, when given,
  the candidate version on the same clock) and of the side speed ``|v_side|`` and the
  commanded yaw rate ``|x|``, one coefficient set per manoeuvre; again on the evaluated runs
  (``shared``), per run (``per_run``) and, when given, on training runs (``trained``).
* **Learned transfer.** A gradient-boosted regressor (scikit-learn
  ``HistGradientBoostingRegressor``) from the wheel-speed history (commanded speed and yaw
  rate now and 1-12 wheel samples back, the time spent in the current manoeuvre, the pitch)
  and the physics predictions is trained on *other* runs of the terrain and scored on the
  evaluated ones (``learned``): whether a history-dependent behaviour that the steady family
  misses (a rut that deepens while the wheels spin, say) is predictable from the inputs.
* **Online ground state.** Each run's chi estimated causally from its own gyro (recursive
  least squares with forgetting, shrunk towards the physics replay) and used to forecast the
  yaw rate ``lead_s`` ahead; for the current, each run's offset from the replay estimated
  the same way (``online``): what estimating the ground state per run, instead of
  simulating it from the terrain label, gives. It uses measured yaw rates and currents, so
  it is not a replay without fitted effects.

All of them are computed on the audit's comparison clock and samples (``score_imu`` /
``score_cur``, moving samples only) so their RMSEs compare directly with the replay's
(:mod:`terrain.audit.physics`). ``benchmarks/explainable_ceiling.py`` runs them on BorealTC
(``docs/physics_v2.md``, section "What one parameter set per terrain can reach").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd
from sklearn.ensemble import HistGradientBoostingRegressor

from terrain.audit.frames import MANOEUVRES, STOP, AuditFrame
from terrain.errors import ConfigError, config_integer, config_positive, refuse_missing
from terrain.run import clock_slack
from terrain.vehicles import HUSKY, side_speeds
from terrain.vehicles.icr import inverse_icr_factor

#: manoeuvre scopes of :func:`ceiling_table` (``moving`` pools the three others)
SCOPES = ("moving", "straight", "curve", "spin")
#: model columns a sample table may hold besides ``reference``
MODELS = ("candidate", "shared", "per_run", "trained", "online", "learned")
#: lags of the learned transfer's history features, in wheel samples (BorealTC: ~0.15 s each)
HISTORY_LAGS = (1, 2, 3, 4, 6, 8, 12)
#: relative singular-value cutoff of the ``trained`` current recalibration: directions the
#: training samples do not determine are left out (truncated least squares). Steady runs
#: make the replays' currents nearly constant within a manoeuvre (SANDY_LOAM's training
#: spins: singular values 1e-7 of the largest), and untruncated least squares then returns
#: coefficients of 1e4-1e5 that cancel on the training samples only (held-out SANDY_LOAM
#: current RMSE 1 700 A against the replay's 3.6 A).
TRAINED_RCOND = 1e-4
#: decimals the learned transfer's inputs are rounded to, in their units (m/s, rad/s, A, s,
#: rad): far below any sensor's resolution, and far above the last-place differences
#: (1e-15-1e-7) by which two builds of the same physics differ. Unrounded, the
#: histogram-binned trees split on those differences: replays constant to 1e-7 within a
#: manoeuvre get bin edges inside that noise, and a change of the compiled kernel's
#: floating-point order (2026-11-26) moved the held-out gains by up to 7 points.
LEARNED_INPUT_DECIMALS = 4
#: sample-table columns that identify a sample
KEY_COLUMNS = ("run_id", "terrain", "side", "manoeuvre", "measured", "reference")


@dataclass(frozen=True)
class TransferSettings:
    """Regressor of :func:`learned_transfer_samples`.

    Parameters
    ----------
    max_iter : int
        Boosting iterations.
    learning_rate : float
        Shrinkage.
    min_samples_leaf : int
        Smallest leaf, samples (the wheel clock of BorealTC is ~6.5 Hz: 40 samples ~ 6 s).
    random_state : int
        Seed of the regressor.

    Raises
    ------
    ConfigError
        ``max_iter`` or ``min_samples_leaf`` not an integer >= 1, ``learning_rate`` not a
        finite number > 0, ``random_state`` not an integer in ``0 .. 2**32 - 1``.
    """

    max_iter: int = 300
    learning_rate: float = 0.05
    min_samples_leaf: int = 40
    random_state: int = 0

    def __post_init__(self) -> None:
        # (NaN or 2.5 iterations passed a '< 1' check and failed later inside scikit-learn)
        config_integer("TransferSettings.max_iter", self.max_iter, 1)
        config_integer("TransferSettings.min_samples_leaf", self.min_samples_leaf, 1)
        config_integer("TransferSettings.random_state", self.random_state, 0, 2 ** 32 - 1)
        config_positive("TransferSettings", learning_rate=self.learning_rate)


def _check_pairs(frames: Sequence[AuditFrame], candidates: Sequence[AuditFrame] | None,
                 one_terrain: bool = False):
    """Candidates on the frames' clocks; with ``one_terrain``, frames of a single terrain
    (the families fitted here have one parameter set per terrain)."""
    if one_terrain and len({f.terrain for f in frames}) > 1:
        raise ConfigError("one terrain at a time: the family has one parameter set per terrain")
    if candidates is not None:
        if len(candidates) != len(frames):
            raise ConfigError(f"{len(candidates)} candidate frames for {len(frames)} frames")
        for f, c in zip(frames, candidates):
            if c.run_id != f.run_id or c.n != f.n:
                raise ConfigError(f"candidate frame of {c.run_id} ({c.n} samples) is not on "
                                  f"the clock of {f.run_id} ({f.n} samples)")


def _yaw_mask(frame: AuditFrame) -> np.ndarray:
    return frame.score_imu & np.isfinite(frame.wz) & (frame.manoeuvre != STOP)


def _cur_mask(frame: AuditFrame) -> np.ndarray:
    return frame.score_cur & (frame.manoeuvre != STOP)


def _side_speed(frame: AuditFrame, side: int, track_m: float) -> np.ndarray:
    """``|v_side|`` of one drive side (0 left, 1 right), m/s: ``v -+ x B / 2`` (seed ``000``
    eq. 2 inverted, :func:`terrain.vehicles.side_speeds`)."""
    return np.abs(side_speeds(frame.commanded_speed, frame.commanded_yaw_rate, track_m,
                              1.0)[side])


def _yaw_rows(frames: Sequence[AuditFrame],
              candidates: Sequence[AuditFrame] | None) -> pd.DataFrame | None:
    """Scored yaw-rate samples of the frames (None where there is none)."""
    parts = []
    for k, f in enumerate(frames):
        m = _yaw_mask(f)
        if not m.any():
            continue
        parts.append(pd.DataFrame({
            "run_id": f.run_id, "terrain": f.terrain, "side": -1, "code": f.manoeuvre[m],
            "x": f.commanded_yaw_rate[m], "measured": f.wz[m], "reference": f.sim_wz[m],
            "candidate": candidates[k].sim_wz[m] if candidates is not None else np.nan}))
    return pd.concat(parts, ignore_index=True) if parts else None


def _or_zero(a: float) -> float:
    """A least-squares ``1 / chi`` to predict with: 0 where it is not defined."""
    return a if np.isfinite(a) else 0.0


def _inverse_chi(measured: np.ndarray, x: np.ndarray) -> float:
    """Least-squares ``1 / chi`` of ``measured = x / chi`` (0 where it is not defined)."""
    return _or_zero(inverse_icr_factor(measured, x))


def _chi_of(a: float) -> float:
    """``chi`` of a least-squares ``1 / chi``: inf where the vehicle does not turn the
    commanded way (``a <= 0``), NaN where ``a`` is not defined (no turn commanded)."""
    return (1.0 / a if a > 0 else np.inf) if np.isfinite(a) else np.nan


def _check_training(frames: Sequence[AuditFrame], candidates: Sequence[AuditFrame] | None,
                    train_frames: Sequence[AuditFrame] | None,
                    train_candidates: Sequence[AuditFrame] | None) -> None:
    """Training runs of the evaluated runs' terrain, disjoint from them, candidates alike."""
    if train_frames is None:
        if train_candidates is not None:
            raise ConfigError("train_candidates without train_frames")
        return
    if (candidates is None) != (train_candidates is None):
        raise ConfigError("give candidate frames for both the training and the evaluated runs, "
                          "or for neither")
    _check_pairs(train_frames, train_candidates, one_terrain=True)
    if frames and {f.terrain for f in train_frames} - {f.terrain for f in frames}:
        raise ConfigError("training runs of another terrain: the family has one parameter set "
                          "per terrain")
    if {f.run_id for f in train_frames} & {f.run_id for f in frames}:
        raise ConfigError("training and evaluated runs overlap")


def yaw_rate_ceiling_samples(frames: Sequence[AuditFrame],
                             candidates: Sequence[AuditFrame] | None = None,
                             train_frames: Sequence[AuditFrame] | None = None) -> pd.DataFrame:
    """Per scored sample: measured yaw rate, the replays' and the steady family's predictions.

    Parameters
    ----------
    frames : sequence of AuditFrame
        The evaluated runs on the comparison clock (:func:`terrain.audit.frames.prepare_frame`),
        ``sim_wz`` the reference replay, rad/s; all of one terrain (one parameter set).
    candidates : sequence of AuditFrame, optional
        The same runs with another physics' predictions on the same clock
        (:func:`terrain.audit.physics.paired_frames`).
    train_frames : sequence of AuditFrame, optional
        Other runs of the same terrain (disjoint run ids): the ``trained`` column's chi per
        manoeuvre is fitted on them.

    Returns
    -------
    pandas.DataFrame
        Columns ``run_id, terrain, side`` (``-1``: not a side signal), ``manoeuvre`` (name),
        ``measured, reference, candidate`` (NaN without candidates), ``shared`` (one
        ``chi_m`` per manoeuvre fitted on all these samples), ``per_run`` (one per run and
        manoeuvre), ``trained`` (one ``chi_m`` per manoeuvre fitted on ``train_frames``;
        NaN without them; where the training runs hold no sample of a manoeuvre, the
        reference replay, counted in ``attrs["trained_fallback"]``), all in rad/s.
        ``attrs["chi_shared"]``: manoeuvre -> fitted ``chi`` of the measured yaw rate (inf
        where the vehicle does not turn the commanded way, NaN where no turn was commanded:
        unknown);
        ``attrs["chi_trained"]`` (only with ``train_frames``): the same on the training runs;
        ``attrs["chi_reference"]`` and ``attrs["chi_candidate"]`` (the latter only with
        ``candidates``): the same least-squares chi of each replay's yaw rate on the same
        samples, so the replays' chi per manoeuvre can be set against the measured one on
        the same commanded turns.

    Raises
    ------
    ConfigError
        Candidate frames not matching the frames, frames of more than one terrain, or
        training runs of another terrain or overlapping the evaluated ones.
    """
    _check_pairs(frames, candidates, one_terrain=True)
    _check_training(frames, None, train_frames, None)
    cols = list(KEY_COLUMNS) + ["candidate", "shared", "per_run", "trained"]
    tab = _yaw_rows(frames, candidates)
    if tab is None:
        return pd.DataFrame(columns=cols)
    tab["shared"] = np.nan
    tab["per_run"] = np.nan
    tab["trained"] = np.nan
    chi = {}
    replay_chi = {"reference": {}, "candidate": {}}
    trained_a, fallback = None, 0
    if train_frames is not None:
        train = _yaw_rows(train_frames, None)
        # (the raw 1 / chi, NaN where no turn was commanded: an unknown chi, not inf)
        trained_a = ({} if train is None else
                     {code: inverse_icr_factor(s.measured.to_numpy(), s.x.to_numpy())
                      for code, s in train.groupby("code")})
    for code, sub in tab.groupby("code"):
        a = inverse_icr_factor(sub.measured.to_numpy(), sub.x.to_numpy())
        chi[MANOEUVRES[code]] = _chi_of(a)
        for name, found in replay_chi.items():
            found[MANOEUVRES[code]] = _chi_of(inverse_icr_factor(sub[name].to_numpy(),
                                                                 sub.x.to_numpy()))
        tab.loc[sub.index, "shared"] = _or_zero(a) * sub.x
        for _, one in sub.groupby("run_id"):
            b = _inverse_chi(one.measured.to_numpy(), one.x.to_numpy())
            tab.loc[one.index, "per_run"] = b * one.x
        if trained_a is not None:
            if code in trained_a:
                tab.loc[sub.index, "trained"] = _or_zero(trained_a[code]) * sub.x
            else:
                tab.loc[sub.index, "trained"] = sub.reference
                fallback += len(sub)
    tab["manoeuvre"] = [MANOEUVRES[c] for c in tab.code]
    out = tab[cols].copy()
    out.attrs["chi_shared"] = chi
    out.attrs["chi_reference"] = replay_chi["reference"]
    if candidates is not None:
        out.attrs["chi_candidate"] = replay_chi["candidate"]
    if trained_a is not None:
        out.attrs["chi_trained"] = {MANOEUVRES[c]: _chi_of(a) for c, a in trained_a.items()}
        out.attrs["trained_fallback"] = fallback
    return out


def _current_design(frame: AuditFrame, cand: AuditFrame | None, side: int,
                    m: np.ndarray, track_m: float) -> np.ndarray:
    cols = [np.ones(int(m.sum())), frame.sim_cur[m, side]]
    if cand is not None:
        cols.append(cand.sim_cur[m, side])
    cols += [_side_speed(frame, side, track_m)[m], np.abs(frame.commanded_yaw_rate[m])]
    return np.column_stack(cols)


def _current_rows(frames: Sequence[AuditFrame], candidates: Sequence[AuditFrame] | None,
                  track_m: float) -> tuple[pd.DataFrame, np.ndarray] | None:
    """Scored current samples of both sides and their recalibration design matrix."""
    rows, designs = [], []
    for k, f in enumerate(frames):
        m = _cur_mask(f)
        if not m.any():
            continue
        cand = candidates[k] if candidates is not None else None
        for side in (0, 1):
            rows.append(pd.DataFrame({
                "run_id": f.run_id, "terrain": f.terrain, "side": side, "code": f.manoeuvre[m],
                "measured": f.cur[m, side], "reference": f.sim_cur[m, side],
                "candidate": cand.sim_cur[m, side] if cand is not None else np.nan}))
            designs.append(_current_design(f, cand, side, m, track_m))
    if not rows:
        return None
    return pd.concat(rows, ignore_index=True), np.vstack(designs)


def _trained_coefficients(A: np.ndarray, y: np.ndarray, base: int) -> np.ndarray:
    """Recalibration coefficients fitted on training samples, well-posed for unseen runs.

    The same affine family as ``shared`` (``y ~ A c``, ``A[:, 0]`` the intercept), fitted as
    a correction of the physics column ``base`` (the candidate replay, else the reference):
    ``y - A[:, base]`` by least squares on the centred other columns, truncated at
    :data:`TRAINED_RCOND`. A direction the training samples do not determine (a replay
    current that is constant within a manoeuvre, or two replays that move together) gets no
    correction, so the physics is kept there instead of an arbitrary split between
    collinear columns.
    """
    res = y - A[:, base]
    X = A[:, 1:]
    mu = X.mean(axis=0)
    beta = np.linalg.lstsq(X - mu, res - res.mean(), rcond=TRAINED_RCOND)[0]
    coef = np.concatenate([[res.mean() - mu @ beta], beta])
    coef[base] += 1.0
    return coef


def current_ceiling_samples(frames: Sequence[AuditFrame],
                            candidates: Sequence[AuditFrame] | None = None,
                            track_m: float = HUSKY.track_m,
                            train_frames: Sequence[AuditFrame] | None = None,
                            train_candidates: Sequence[AuditFrame] | None = None
                            ) -> pd.DataFrame:
    """Per scored sample and side: measured current, the replays' and the recalibrations'.

    Parameters
    ----------
    frames : sequence of AuditFrame
        The evaluated runs (one terrain), ``sim_cur`` the reference replay, A.
    candidates : sequence of AuditFrame, optional
        The same runs with another physics' currents on the same clock; they enter the
        recalibration as a regressor too.
    track_m : float
        Track width of the vehicle, m (default: the Husky A200's,
        :data:`terrain.vehicles.HUSKY`), for the side speeds.
    train_frames, train_candidates : sequence of AuditFrame, optional
        Other runs of the same terrain (disjoint run ids) and, exactly when ``candidates``
        are given, their candidate frames: the ``trained`` column's coefficients are fitted
        on them.

    Returns
    -------
    pandas.DataFrame
        Columns ``run_id, terrain, side`` (0 left, 1 right), ``manoeuvre``, ``measured,
        reference, candidate, shared, per_run, trained`` (A). ``shared``: per manoeuvre,
        least squares of the measured current on ``[1, reference, (candidate), |v_side|,
        |x|]`` over all these samples, both sides together (the physics is symmetric: one
        set for both); ``per_run``: the same per run and manoeuvre (where a run has fewer
        than 3 rows, samples times sides, per coefficient in a manoeuvre, its ``shared``
        value is kept: those rows are counted in ``attrs["per_run_fallback"]``);
        ``trained``: the family of ``shared`` fitted on the training runs instead, as a
        correction of the candidate replay (the reference without candidates) by truncated
        least squares (:data:`TRAINED_RCOND`), and applied here (NaN without training
        runs; where they hold fewer than 3 rows per coefficient of a manoeuvre, the
        reference replay, counted in ``attrs["trained_fallback"]``).

    Raises
    ------
    ConfigError
        Candidate frames not matching the frames, frames of more than one terrain, or
        training runs of another terrain, overlapping the evaluated ones, or with
        candidates where the evaluated runs have none (or the reverse).
    """
    _check_pairs(frames, candidates, one_terrain=True)
    _check_training(frames, candidates, train_frames, train_candidates)
    cols = list(KEY_COLUMNS) + ["candidate", "shared", "per_run", "trained"]
    found = _current_rows(frames, candidates, track_m)
    if found is None:
        return pd.DataFrame(columns=cols)
    tab, A = found
    y = tab.measured.to_numpy(float)
    shared = np.full(len(tab), np.nan)
    per_run = np.full(len(tab), np.nan)
    trained = np.full(len(tab), np.nan)
    fallback = trained_fallback = 0
    need = 3 * A.shape[1]
    coef_trained = None
    if train_frames is not None:
        train = _current_rows(train_frames, train_candidates, track_m)
        coef_trained = {}
        if train is not None:
            t_tab, t_A = train
            t_y = t_tab.measured.to_numpy(float)
            base = 2 if candidates is not None else 1
            for code, sub in t_tab.groupby("code"):
                i = sub.index.to_numpy()
                if len(i) >= need:
                    coef_trained[code] = _trained_coefficients(t_A[i], t_y[i], base)
    for code, sub in tab.groupby("code"):
        i = sub.index.to_numpy()
        shared[i] = A[i] @ np.linalg.lstsq(A[i], y[i], rcond=None)[0]
        for _, one in sub.groupby("run_id"):
            j = one.index.to_numpy()
            if len(j) < need:
                per_run[j] = shared[j]
                fallback += len(j)
            else:
                per_run[j] = A[j] @ np.linalg.lstsq(A[j], y[j], rcond=None)[0]
        if coef_trained is not None:
            if code in coef_trained:
                trained[i] = A[i] @ coef_trained[code]
            else:
                trained[i] = sub.reference.to_numpy(float)
                trained_fallback += len(i)
    tab["shared"], tab["per_run"], tab["trained"] = shared, per_run, trained
    tab["manoeuvre"] = [MANOEUVRES[c] for c in tab.code]
    out = tab[cols].copy()
    out.attrs["per_run_fallback"] = fallback
    if coef_trained is not None:
        out.attrs["trained_fallback"] = trained_fallback
    return out


def history_features(frame: AuditFrame, prediction: np.ndarray,
                     lags: Sequence[int] = HISTORY_LAGS) -> np.ndarray:
    """Inputs of the learned transfer at every sample of a frame.

    Parameters
    ----------
    frame : AuditFrame
        A run on the comparison clock.
    prediction : ndarray, shape (n,) or (n, k)
        Physics prediction(s) of the target signal at the frame's samples.
    lags : sequence of int
        Past samples of the commanded speed and yaw rate included, in wheel samples (each
        an integer >= 1).

    Returns
    -------
    ndarray, shape (n, 6 + 2 len(lags) + k)
        ``x, v, |x|, |v|``, ``x`` and ``v`` at every lag (the first sample repeated before
        the run starts), the time in the current manoeuvre (s), the pitch (rad) and the
        prediction(s).

    Raises
    ------
    ConfigError
        A lag that is not an integer >= 1 (0 built an empty column, a negative lag a
        negative array size, 1.5 a float slice index: numpy's bare errors).
    """
    for i, lag in enumerate(lags):
        config_integer(f"history_features lags[{i}]", lag, 1)
    x, v = frame.commanded_yaw_rate, frame.commanded_speed
    cols = [x, v, np.abs(x), np.abs(v)]
    for lag in lags:
        cols += [np.r_[np.full(min(lag, len(x)), x[0]), x[:-lag]][:len(x)],
                 np.r_[np.full(min(lag, len(v)), v[0]), v[:-lag]][:len(v)]]
    # time since the manoeuvre last changed, s
    change = np.r_[True, frame.manoeuvre[1:] != frame.manoeuvre[:-1]]
    start = np.maximum.accumulate(np.where(change, np.arange(len(x)), 0))
    cols += [frame.t_s - frame.t_s[start], frame.pitch]
    pred = np.asarray(prediction, dtype=float)
    return np.column_stack(cols + [pred.reshape(len(x), -1)])


def _learner_inputs(frame: AuditFrame, prediction: np.ndarray) -> np.ndarray:
    """:func:`history_features` rounded to :data:`LEARNED_INPUT_DECIMALS`: the learned
    transfer's inputs, the same for fitting and predicting."""
    return np.round(history_features(frame, prediction), LEARNED_INPUT_DECIMALS)


def _signal_samples(frame: AuditFrame, cand: AuditFrame | None, signal: str):
    """(mask, target, predictions (n, k), reference, candidate) of one signal of one frame."""
    if signal == "wz":
        m = _yaw_mask(frame)
        ref = frame.sim_wz
        can = cand.sim_wz if cand is not None else None
        y = frame.wz
    else:
        side = {"cur_l": 0, "cur_r": 1}[signal]
        m = _cur_mask(frame)
        ref = frame.sim_cur[:, side]
        can = cand.sim_cur[:, side] if cand is not None else None
        y = frame.cur[:, side]
    pred = ref[:, None] if can is None else np.column_stack([ref, can])
    return m, y, pred, ref, can


def learned_transfer_samples(train: Sequence[AuditFrame], test: Sequence[AuditFrame],
                             signal: str,
                             train_candidates: Sequence[AuditFrame] | None = None,
                             test_candidates: Sequence[AuditFrame] | None = None,
                             settings: TransferSettings = TransferSettings()) -> pd.DataFrame:
    """Train a regressor on some runs of a terrain, predict a signal on the others.

    Parameters
    ----------
    train, test : sequence of AuditFrame
        Training and evaluated runs of one terrain (disjoint run ids).
    signal : {"wz", "cur_l", "cur_r"}
        Target: gyro yaw rate (rad/s) or one side's current (A).
    train_candidates, test_candidates : sequence of AuditFrame, optional
        The same runs with another physics' predictions (both or neither).
    settings : TransferSettings
        Regressor settings.

    Returns
    -------
    pandas.DataFrame
        Columns ``run_id, terrain, side, manoeuvre, measured, reference, candidate,
        learned`` for the scored moving samples of ``test``.

    Raises
    ------
    ConfigError
        Unknown signal, overlapping runs, runs of more than one terrain (training and
        evaluated together), candidates for one set only, or no training sample.
    """
    if signal not in ("wz", "cur_l", "cur_r"):
        raise ConfigError(f"signal must be wz, cur_l or cur_r, got {signal!r}")
    if (train_candidates is None) != (test_candidates is None):
        raise ConfigError("give candidate frames for both the training and the evaluated runs")
    if {f.run_id for f in train} & {f.run_id for f in test}:
        raise ConfigError("training and evaluated runs overlap")
    # one terrain, as the steady families (a mix trained across terrains without a word)
    _check_pairs(train, train_candidates, one_terrain=True)
    _check_pairs(test, test_candidates, one_terrain=True)
    if test and {f.terrain for f in train} - {f.terrain for f in test}:
        raise ConfigError("training runs of another terrain: the transfer is learned within "
                          "one terrain")
    X, y = [], []
    for k, f in enumerate(train):
        cand = train_candidates[k] if train_candidates is not None else None
        m, target, pred, _, _ = _signal_samples(f, cand, signal)
        if m.any():
            X.append(_learner_inputs(f, pred)[m])
            y.append(target[m])
    if not X:
        raise ConfigError(f"no scored training sample of {signal}")
    model = HistGradientBoostingRegressor(
        max_iter=settings.max_iter, learning_rate=settings.learning_rate,
        min_samples_leaf=settings.min_samples_leaf, random_state=settings.random_state)
    model.fit(np.vstack(X), np.concatenate(y))
    side = {"wz": -1, "cur_l": 0, "cur_r": 1}[signal]
    parts = []
    for k, f in enumerate(test):
        cand = test_candidates[k] if test_candidates is not None else None
        m, target, pred, ref, can = _signal_samples(f, cand, signal)
        if not m.any():
            continue
        parts.append(pd.DataFrame({
            "run_id": f.run_id, "terrain": f.terrain, "side": side,
            "manoeuvre": [MANOEUVRES[c] for c in f.manoeuvre[m]], "measured": target[m],
            "reference": ref[m], "candidate": can[m] if can is not None else np.nan,
            "learned": model.predict(_learner_inputs(f, pred)[m])}))
    cols = list(KEY_COLUMNS) + ["candidate", "learned"]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=cols)


def _sample_period_s(frame: AuditFrame) -> float:
    """Median step of a frame's wheel clock, s (0 for a single sample)."""
    return float(np.median(np.diff(frame.t_s))) if frame.n > 1 else 0.0


def _forgetting_sums(t: np.ndarray, code: np.ndarray, terms: Sequence[np.ndarray],
                     lead_s: float, memory_s: float) -> list[np.ndarray]:
    """Exponentially forgetting sums of ``terms`` over earlier samples of the same code.

    For each sample ``k``: ``sum_j terms[j] exp(-(t_k - lead - t_j) / memory)`` over the
    samples ``j`` of the same manoeuvre code with ``t_j <= t_k - lead`` within the clock's
    rounding (:func:`terrain.run.clock_slack`), so a sample exactly ``lead`` earlier on a
    regular clock is used on any clock's origin (0 where none).
    """
    out = [np.zeros(len(t)) for _ in terms]
    for c in np.unique(code):
        i = np.flatnonzero(code == c)
        sums = np.zeros((len(terms), len(i)))
        acc = np.zeros(len(terms))
        for n, j in enumerate(i):
            if n:
                acc *= np.exp(-(t[j] - t[i[n - 1]]) / memory_s)
            acc += [term[j] for term in terms]
            sums[:, n] = acc
        # the sums at t - lead: those of the last sample of this manoeuvre at or before it,
        # decayed to t - lead; "at or before" within the clock's rounding
        avail = np.searchsorted(t[i], t[i] - lead_s + clock_slack(t[i]), side="right") - 1
        ok = avail >= 0
        src = np.maximum(avail, 0)
        decay = np.exp(-np.maximum(t[i] - lead_s - t[i[src]], 0.0) / memory_s)
        for k in range(len(terms)):
            out[k][i] = np.where(ok, sums[k, src] * decay, 0.0)
    return out


def _check_online(owner: str, frames: Sequence[AuditFrame],
                  candidates: Sequence[AuditFrame] | None, lead_s: float, memory_s: float,
                  prior_s: float) -> None:
    """The inputs of the online forecasts: ``lead_s`` and ``prior_s`` finite and >= 0,
    ``memory_s`` finite and > 0 (NaN passed ``lead_s < 0``, and every forecast then fell
    back to the replay without a word), candidates on the frames' clocks."""
    config_positive(owner, allow_zero=True, lead_s=lead_s, prior_s=prior_s)
    config_positive(owner, memory_s=memory_s)
    _check_pairs(frames, candidates)


def online_yaw_rate_samples(frames: Sequence[AuditFrame],
                            candidates: Sequence[AuditFrame] | None = None,
                            lead_s: float = 2.0, memory_s: float = 30.0,
                            prior_s: float = 5.0) -> pd.DataFrame:
    """Yaw rate forecast with each run's chi estimated causally from its own gyro.

    The constructive answer to a ground state that varies between runs of one terrain
    (:func:`yaw_rate_ceiling_samples`, ``per_run``). Per run and manoeuvre, the evidence is the
    exponentially weighted sums ``S_xx = sum w x^2 dt`` and ``S_xy = sum w x wz dt`` over that
    manoeuvre's earlier samples (forgetting time constant ``memory_s``); the forecast at ``t``
    uses only the sums available at ``t - lead_s`` and shrinks the gyro's slope towards the
    physics replay (the candidate's when given, else the reference's):

        wz_hat(t) = (W0 sim_wz(t) + S_xy(t - lead) x(t)) / (W0 + S_xx(t - lead))

    with ``W0 = 0.25 prior_s`` (the weight of ``prior_s`` seconds of turning at 0.5 rad/s).
    With no evidence the forecast is the replay; with much, it is ``x / chi_run``.

    Parameters
    ----------
    frames : sequence of AuditFrame
        Runs on the comparison clock (``wz`` the gyro, ``sim_wz`` the reference replay,
        rad/s).
    candidates : sequence of AuditFrame, optional
        The same runs with another physics' replay: used as the prior.
    lead_s : float
        Forecast horizon, s (>= 0): no sample within ``lead_s`` of ``t`` is used.
    memory_s : float
        Time constant of the exponential forgetting, s (> 0).
    prior_s : float
        Weight of the replay, in seconds of turning at 0.5 rad/s (>= 0; 0: the replay only
        where there is no evidence yet).

    Returns
    -------
    pandas.DataFrame
        Columns ``run_id, terrain, side, manoeuvre, measured, reference, candidate, online``
        (rad/s) for the scored moving samples, in the order of
        :func:`yaw_rate_ceiling_samples`.

    Raises
    ------
    ConfigError
        ``lead_s`` or ``prior_s`` not a finite value >= 0, ``memory_s`` not a finite value
        > 0, or candidates not matching.

    References
    ----------
    Recursive least squares with exponential forgetting (Ljung, *System Identification*,
    2nd ed., 1999, ch. 11.2) of the ICR expansion model ``wz = x / chi`` (Mandow et al., IROS
    2007; seed ``000_f24201ff985633bf.txt`` eqs. 2-3), with the replay as the prior.
    """
    _check_online("online_yaw_rate_samples", frames, candidates, lead_s, memory_s, prior_s)
    w0 = 0.25 * prior_s
    parts = []
    for k, f in enumerate(frames):
        m = _yaw_mask(f)
        if not m.any():
            continue
        t, x, y, code = f.t_s[m], f.commanded_yaw_rate[m], f.wz[m], f.manoeuvre[m]
        prior = (candidates[k] if candidates is not None else f).sim_wz[m]
        dt = _sample_period_s(f)
        xx_at, xy_at = _forgetting_sums(t, code, (x ** 2 * dt, x * y * dt), lead_s, memory_s)
        den = w0 + xx_at
        online = np.divide(w0 * prior + xy_at * x, den, out=prior.copy(), where=den > 0)
        parts.append(pd.DataFrame({
            "run_id": f.run_id, "terrain": f.terrain, "side": -1,
            "manoeuvre": [MANOEUVRES[c] for c in code], "measured": y,
            "reference": f.sim_wz[m],
            "candidate": candidates[k].sim_wz[m] if candidates is not None else np.nan,
            "online": online}))
    cols = list(KEY_COLUMNS) + ["candidate", "online"]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=cols)


def online_current_samples(frames: Sequence[AuditFrame],
                           candidates: Sequence[AuditFrame] | None = None,
                           lead_s: float = 2.0, memory_s: float = 15.0,
                           prior_s: float = 2.0) -> pd.DataFrame:
    """Motor current forecast with each run's current offset estimated causally.

    The current counterpart of :func:`online_yaw_rate_samples`: per run, side and manoeuvre,
    the physics replay (the candidate's when given) is corrected by the exponentially
    weighted mean of its residual (measured minus replayed current) over earlier samples,
    available at ``t - lead_s`` and shrunk towards zero by a prior of ``prior_s`` seconds:

        I_hat(t) = sim(t) + R(t - lead) / (prior_s + W(t - lead))

    with ``W = sum w dt`` and ``R = sum w (I - sim) dt`` (forgetting time constant
    ``memory_s``). It uses measured currents, so it is not a replay without fitted effects.

    Parameters
    ----------
    frames : sequence of AuditFrame
        Runs on the comparison clock (``cur`` measured, ``sim_cur`` the reference replay, A).
    candidates : sequence of AuditFrame, optional
        The same runs with another physics' currents: the ones corrected.
    lead_s : float
        Forecast horizon, s (>= 0).
    memory_s : float
        Forgetting time constant, s (> 0).
    prior_s : float
        Weight of a zero correction, s (>= 0).

    Returns
    -------
    pandas.DataFrame
        Columns ``run_id, terrain, side, manoeuvre, measured, reference, candidate, online``
        (A), rows in the order of :func:`current_ceiling_samples`.

    Raises
    ------
    ConfigError
        ``lead_s`` or ``prior_s`` not a finite value >= 0, ``memory_s`` not a finite value
        > 0, or candidates not matching.
    """
    _check_online("online_current_samples", frames, candidates, lead_s, memory_s, prior_s)
    parts = []
    for k, f in enumerate(frames):
        m = _cur_mask(f)
        if not m.any():
            continue
        t, code = f.t_s[m], f.manoeuvre[m]
        dt = _sample_period_s(f)
        base = (candidates[k] if candidates is not None else f).sim_cur[m]
        for side in (0, 1):
            y = f.cur[m, side]
            w, r = _forgetting_sums(t, code, (np.full(len(t), dt), (y - base[:, side]) * dt),
                                    lead_s, memory_s)
            den = prior_s + w
            correction = np.divide(r, den, out=np.zeros_like(r), where=den > 0)
            parts.append(pd.DataFrame({
                "run_id": f.run_id, "terrain": f.terrain, "side": side,
                "manoeuvre": [MANOEUVRES[c] for c in code], "measured": y,
                "reference": f.sim_cur[m, side],
                "candidate": candidates[k].sim_cur[m, side] if candidates is not None
                else np.nan,
                "online": base[:, side] + correction}))
    cols = list(KEY_COLUMNS) + ["candidate", "online"]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=cols)


def ceiling_table(samples: pd.DataFrame) -> pd.DataFrame:
    """RMSE of the reference and of every model column, and its gain, per manoeuvre scope.

    Parameters
    ----------
    samples : pandas.DataFrame
        Sample tables of this module (several terrains may be concatenated: each row keeps
        the prediction its own terrain's fit made).

    Returns
    -------
    pandas.DataFrame
        One row per scope with samples (``moving`` = straight, curve and spin): ``scope, n,
        n_runs, rmse_reference`` and, for each model column present with finite values,
        ``rmse_<model>`` and ``gain_<model> = 1 - rmse_<model> / rmse_reference``.

    Raises
    ------
    NonFiniteInputError
        A model column holds values on some samples only (tables concatenated with and
        without candidate frames or training runs): its RMSE would be NaN, or taken over
        other samples than the reference's.
    """
    models = [c for c in MODELS if c in samples.columns and samples[c].notna().any()]
    for c in models:
        refuse_missing("ceiling_table", c, samples[c], "value(s)",
                       "give every concatenated table this model, or none")
    rows = []
    for scope in SCOPES:
        sub = samples if scope == "moving" else samples[samples.manoeuvre == scope]
        if sub.empty:
            continue
        y = sub.measured.to_numpy(float)
        ref = float(np.sqrt(np.mean((y - sub.reference.to_numpy(float)) ** 2)))
        row = {"scope": scope, "n": len(sub), "n_runs": sub.run_id.nunique(),
               "rmse_reference": ref}
        for c in models:
            r = float(np.sqrt(np.mean((y - sub[c].to_numpy(float)) ** 2)))
            row[f"rmse_{c}"] = r
            row[f"gain_{c}"] = 1.0 - r / ref if ref > 0 else np.nan
        rows.append(row)
    return pd.DataFrame(rows)


__all__ = [
    "HISTORY_LAGS",
    "MODELS",
    "SCOPES",
    "TRAINED_RCOND",
    "TransferSettings",
    "ceiling_table",
    "current_ceiling_samples",
    "history_features",
    "learned_transfer_samples",
    "online_current_samples",
    "online_yaw_rate_samples",
    "yaw_rate_ceiling_samples",
]
