"""Review trk24: the seams of the benchmarks: what one reads from another module's output
(a ``terrain cv`` run's predictions) is read in that module's format, the formulas and
metrics are the producers' own, and every printed figure is the logged one."""

from __future__ import annotations

import re
import runpy
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
from sklearn.dummy import DummyClassifier

from terrain.models.cv import cross_validate
from terrain.run import Run

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"


def _cv_predictions(seeds):
    """Out-of-fold predictions of 4 runs x 5 windows of 2 s, as cross_validate writes them
    (one row per window and seed), and the runs (a left spin in the first 10 s of each)."""
    runs, rows = [], []
    t = np.arange(0.0, 20.0, 0.01)
    imu = pd.DataFrame({"t_s": t, "wz": np.where(t < 10.0, 0.3, 0.0)})
    for k, label in enumerate(["A", "A", "B", "B"]):
        run_id = f"x/{label}/{k}"
        runs.append(Run(run_id, "x", label, {"imu": imu}))
        rows += [(run_id, label, 4.0 * i, 4.0 * i + 2.0) for i in range(5)]
    run_ids = np.array([r[0] for r in rows])
    y = np.array([r[1] for r in rows])
    X = np.arange(len(rows), dtype=float)[:, None]
    report = cross_validate(lambda seed: DummyClassifier(strategy="most_frequent"), X, y,
                            run_ids, run_ids, np.array([r[2] for r in rows]),
                            np.array([r[3] for r in rows]), seeds=seeds, n_splits=2)
    return report.predictions, runs, len(rows)


def _errors_by_manoeuvre(tmp_path, monkeypatch, capsys, predictions, runs):
    script = runpy.run_path(str(BENCHMARKS / "errors_by_manoeuvre.py"))
    csv = tmp_path / "predictions.csv"
    predictions.to_csv(csv, index=False)        # what terrain cv logs (TrackedRun.log_table)
    env = script["main"].__globals__
    monkeypatch.setitem(env, "activate_store", lambda: None)
    monkeypatch.setitem(env, "mlflow", SimpleNamespace(artifacts=SimpleNamespace(
        download_artifacts=lambda **k: str(csv))))
    monkeypatch.setitem(env, "load_dataset", lambda name: runs)
    monkeypatch.setattr(sys, "argv", ["errors_by_manoeuvre.py", "RUN"])
    assert script["main"]() == 0
    return capsys.readouterr().out


def test_errors_by_manoeuvre_counts_each_window_of_a_multi_seed_cv_run_once(
        tmp_path, monkeypatch, capsys):
    # terrain cv's predictions.csv holds every window once per seed (3 by default): the
    # script said "60 out-of-fold windows" for 20, and its table's sizes were 3x too
    one, runs, n = _cv_predictions((0,))
    three, _, _ = _cv_predictions((0, 1, 2))
    assert len(three) == 3 * n                   # the producer's format
    out_one = _errors_by_manoeuvre(tmp_path, monkeypatch, capsys, one, runs)
    out_three = _errors_by_manoeuvre(tmp_path, monkeypatch, capsys, three, runs)
    assert re.search(rf"\b{n} out-of-fold windows\b", out_one)
    assert re.search(rf"\b{n} out-of-fold windows\b", out_three)
    # the same windows, the same table (accuracy pooled over seeds, sizes in windows)
    body = (lambda out: out.split("\n", 1)[1])
    assert body(out_one) == body(out_three)


def test_sweep_soil_params_chi_takes_its_commanded_yaw_rate_from_the_kinematics(monkeypatch):
    # sim_chi wrote the ideal differential-drive yaw rate (v_R - v_L) / B out itself beside
    # terrain.vehicles.skid_steer.skid_steer_forward (seed 000 eq. 2), which the audit's
    # measured chi uses: one formula, one place, left = motor 0 as the simulator's motors
    from terrain.vehicles import HUSKY
    from terrain.vehicles.icr import icr_expansion_factor
    from terrain.vehicles.skid_steer import skid_steer_forward

    script = runpy.run_path(str(BENCHMARKS / "sweep_soil_params.py"))
    env = script["sim_chi"].__globals__
    rng = np.random.default_rng(0)
    omega = rng.uniform(-5.0, 5.0, (200, 2))
    twist = np.zeros((200, 3))
    twist[:, 2] = rng.uniform(-1.0, 1.0, 200)
    physics = SimpleNamespace(omega=omega, twist=twist)
    monkeypatch.setitem(env, "simulate_with_physics",
                        lambda config: SimpleNamespace(physics=physics))
    calls = []

    def forward(*args, **kwargs):
        calls.append(args)
        return skid_steer_forward(*args, **kwargs)

    monkeypatch.setitem(env, "skid_steer_forward", forward)
    chi = script["sim_chi"]("SNOW", "spin", 32.0)
    assert calls, "sim_chi does not call skid_steer_forward"
    _, x = skid_steer_forward(omega[:, 0] * HUSKY.wheel_radius_m,
                              omega[:, 1] * HUSKY.wheel_radius_m, HUSKY.track_m)
    m = np.abs(x) > 0.1
    assert chi == icr_expansion_factor(twist[m, 2], x[m])


def test_slip_nees_logs_every_figure_it_prints(monkeypatch, capsys):
    # docs/slip_learning.md: "NEES by seed block, with triplet and pooled tests (...; logged
    # to MLflow run slip-nees)"; the pooled test (mean and bounds) and the spread of the run
    # means were printed but not logged
    script = runpy.run_path(str(BENCHMARKS / "slip_nees.py"))
    env = script["main"].__globals__
    rng = np.random.default_rng(0)

    def run(terrain, seconds):     # runs of unequal length: the pooled mean is not the mean
        t = np.arange(0.0, seconds, 0.1)    # of the run means
        truth = pd.DataFrame({"t_s": t, "slip_1": 0.05, "slip_2": 0.06})
        return SimpleNamespace(terrain=terrain, streams={"truth": truth})

    runs = [run(terrain, 5.0 + 3 * k) for terrain in ("SNOW", "ICE") for k in range(6)]

    def estimate(r, source, outputs, settings):
        t = r.streams["truth"]["t_s"].to_numpy()
        x = np.column_stack([0.05 + 0.01 * rng.standard_normal(t.size),
                             0.06 + 0.01 * rng.standard_normal(t.size)])
        P = np.broadcast_to(np.eye(2) * 1e-4 * rng.uniform(0.5, 2.0), (t.size, 2, 2))
        return SimpleNamespace(ekf=SimpleNamespace(state_names=["slip_1", "slip_2"], t_s=t,
                                                   x=x, P=P))

    logged = {}

    class Run:
        def log_metrics(self, metrics):
            logged.update(metrics)

    from contextlib import contextmanager

    @contextmanager
    def tracked(*args, **kwargs):
        yield Run()

    monkeypatch.setitem(env, "require_store", lambda: "sqlite:///x.db")
    monkeypatch.setitem(env, "resolve_slip_model", lambda name: (None, None))
    monkeypatch.setitem(env, "simulated_runs", lambda spec, cache: runs)
    monkeypatch.setitem(env, "slip_model_outputs", lambda r, model, sim: None)
    monkeypatch.setitem(env, "estimate_skid_steer_slip_run", estimate)
    monkeypatch.setitem(env, "tracked_run", tracked)
    monkeypatch.setattr(sys, "argv", ["slip_nees.py", "--seeds", "0-5"])
    assert script["main"]() == 0
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if "mean NEES" in line]
    assert len(lines) == 2
    for line in lines:
        terrain = line.split()[0]
        printed = [float(v) for v in re.findall(r"-?\d+\.\d+", line)]
        # mean +- spread, pooled mean [lower, upper]: every printed figure is a metric
        mine = {round(v, 2) for k, v in logged.items() if k.startswith(f"s0.{terrain}.")}
        missing = [v for v in printed if round(v, 2) not in mine]
        assert not missing, (line, sorted(k for k in logged if terrain in k))


def test_vulpi_probes_scores_with_the_projects_window_metrics(monkeypatch):
    # vulpi_probes.py scored its variants with scikit-learn's accuracy_score and f1_score
    # beside terrain.models.metrics.window_metrics, the project's definitions that terrain
    # cv and every other benchmark report: one definition, one place
    from terrain.models import metrics as project_metrics

    script = runpy.run_path(str(BENCHMARKS / "vulpi_probes.py"))
    env = script["borealtc_scaler_check"].__globals__
    rng = np.random.default_rng(0)
    labels = np.repeat(np.array(["A", "B", "C"]), 20)
    groups = np.repeat(np.arange(12), 5)
    vulpi = np.zeros(labels.size, dtype=bool)
    vulpi[-5:] = True
    c = {"vulpi": vulpi, "labels": labels, "F": rng.standard_normal((labels.size, 3)),
         "groups": groups, "config": SimpleNamespace(svm=None)}
    monkeypatch.setitem(env, "probe_windows", lambda dataset, rate: c)
    monkeypatch.setitem(env, "make_svm", lambda svm, seed: DummyClassifier(
        strategy="stratified", random_state=seed))
    monkeypatch.setitem(env, "_scaler_from_all_predict",
                        lambda cfg, F, y, F_test, F_all: rng.choice(["A", "B", "D"],
                                                                    len(F_test)))
    calls = []

    def spy(y_true, y_pred, classes):
        calls.append(1)
        return project_metrics.window_metrics(y_true, y_pred, classes)

    monkeypatch.setitem(env, "window_metrics", spy)
    rows = script["borealtc_scaler_check"]([0, 1])
    assert calls, "vulpi_probes does not score with window_metrics"
    assert len(calls) == len(rows) == 4


# bench_control.py's make_inputs wrote omega = v / (1 - s) / r for every slip, the traction
# inverse: a braking slip s was timed as the SAE slip s / (1 - s)
def test_bench_control_wheel_speeds_carry_the_slip_they_are_timed_with():
    from terrain.slip import sae_slip

    script = runpy.run_path(str(BENCHMARKS / "bench_control.py"))
    x = script["make_inputs"](2000, 3, np.random.default_rng(0))
    radius = script["WHEEL_RADIUS_M"]
    inside = np.abs(x["slip"]) < 0.5                      # make_inputs clips at +-0.5
    computed = sae_slip(x["omega"] * radius, x["v_long"])
    np.testing.assert_allclose(computed[inside], x["slip"][inside], atol=1e-9)
