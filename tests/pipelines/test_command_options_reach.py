"""Options of the simulation and closed-loop commands reach what they configure, and the
notes and outputs say what the run holds (pipelines/simulate.py,
control_sim.py, control_grid.py, stream_eval.py, slip_fit.py, compare.py, serve.py and
audit.py)."""

from __future__ import annotations

import json
from dataclasses import replace

import pandas as pd
import pytest
from cli_helpers import RecordingRun, control_sim_json

import pipelines.control_sim as control_sim
from pipelines.simulate import unreached_terrains_note
from terrain.cli import main
from terrain.sim import SimConfig, simulate


def test_simulate_physics_option_reaches_the_run_and_the_run_number_is_shown(
        tmp_path, capsys):
    # --physics v2 was simulated as the default physics (v1) without a word if dropped
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--duration-s", "0.5",
                 "--physics", "v2", "--out", str(tmp_path)]) == 0
    meta = json.loads((tmp_path / "ICE" / "meta_00.json").read_text())
    assert meta["physics"] == "v2"
    assert "(run 00)" in capsys.readouterr().out    # the XX of the files written
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--duration-s", "0.5",
                 "--out", str(tmp_path)]) == 0
    assert json.loads((tmp_path / "ICE" / "meta_01.json").read_text())["physics"] == "v1"
    assert "(run 01)" in capsys.readouterr().out


def test_unreached_terrain_note_gives_the_path_length_in_the_plane():
    # a 3-4-5 path twice: 10 m in the plane (6 m along x alone)
    config = SimConfig(vehicle="husky", terrains=("ICE", "SNOW"), scenario="spin",
                       duration_s=0.5, segment_length_m=20.0)
    run = simulate(config)
    truth = pd.DataFrame({"t_s": [0.0, 1.0, 2.0], "x": [0.0, 3.0, 6.0], "y": [0.0, 4.0, 8.0],
                          "terrain": ["ICE"] * 3})
    note = unreached_terrains_note(replace(run, streams={**run.streams, "truth": truth}),
                                   config)
    assert note == ("note: terrain(s) SNOW never reached: the path covers 10.0 m and the "
                    "terrain changes every 20 m (--segment-m); the run holds ICE only")


def _control_sim(tmp_path, *extra):
    return control_sim_json(tmp_path, "--duration-s", "0.5", *extra)


def test_control_sim_gains_given_are_the_gains_run(tmp_path):
    r = _control_sim(tmp_path, "--controller", "traction", "--terrain-source", "label",
                     "--kp", "7", "--ki", "3")
    assert (r["kp"], r["ki"]) == (7.0, 3.0)
    r = _control_sim(tmp_path, "--controller", "traction", "--terrain-source", "label",
                     "--ki", "4")
    assert (r["kp"], r["ki"]) == (2.0, 4.0)       # kp: the fused estimator's tuned default


def test_control_sim_passes_the_live_sim_classifier_options_on(tmp_path, monkeypatch):
    """The live-sim classifier is trained on the runs the options describe: the gains,
    estimator, feed-forward, seeds and the uncontrolled-only flag (caught here before any
    training)."""
    calls = []

    def capture(source, vehicle, terrains, seeds, model, classifier_seeds, **kwargs):
        calls.append(dict(source=source, seeds=seeds, classifier_seeds=classifier_seeds,
                          **kwargs))
        return None, {"terrain_source": source}

    monkeypatch.setattr(control_sim, "decision_source", capture)
    r = _control_sim(tmp_path, "--controller", "off", "--classifier-uncontrolled-only",
                     "--classifier-seeds", "3000", "--seed", "4")
    assert calls[-1]["controlled_runs"] is False and calls[-1]["classifier_seeds"] == [3000]
    assert calls[-1]["seeds"] == [4] and r["seed"] == 4 and r["controller"] == "off"
    _control_sim(tmp_path, "--controller", "off", "--kp", "6", "--ki", "1",
                 "--no-feed-forward", "--estimator", "observer")
    assert calls[-1]["controlled_runs"] is True and calls[-1]["gains"] == (6.0, 1.0)
    assert calls[-1]["feed_forward"] is False and calls[-1]["estimator"] == "observer"
    assert calls[-1]["classifier_seeds"] == control_sim.CLASSIFIER_SEEDS


def test_control_sim_controller_and_feed_forward_options_reach_the_loop(tmp_path):
    """On ICE the uncontrolled Husky spins its wheels at start-up (peak slip 0.47 in 2 s);
    the traction controller holds it near its target (0.11), and without its feed-forward
    the 2 s start-up is the uncontrolled one. The JSON names the terrain as catalogued."""
    common = ("--terrain-source", "label", "--duration-s", "2")
    off = _control_sim(tmp_path, "--controller", "off", *common)
    on = _control_sim(tmp_path, "--controller", "traction", *common)
    feedback = _control_sim(tmp_path, "--controller", "traction", "--no-feed-forward",
                            *common)
    assert off["controller"] == "off" and off["peak_slip"] > 0.4
    assert on["peak_slip"] < 0.2 and on["feed_forward"] is True
    assert feedback["feed_forward"] is False and feedback["peak_slip"] > 0.4
    assert off["terrain"] == on["terrain"] == "ICE"     # given as "ice"


def test_control_grid_refuses_a_repeated_proportional_gain(tmp_path, monkeypatch, capsys):
    # each candidate would be tuned twice and tabulated twice in tuning_<vehicle>.csv
    monkeypatch.chdir(tmp_path)
    assert main(["control-grid", "--kp-grid", "2", "5", "2", "--out", "g"]) == 2
    err = capsys.readouterr().err
    assert "--kp-grid: [2.0] given more than once (each gain once)" in err
    assert not any(tmp_path.iterdir())


class _Stop(Exception):
    """Raised by the stand-in of the grid run, once its arguments are recorded."""


def test_control_grid_runs_the_estimator_gains_and_feed_forward_asked_for(tmp_path,
                                                                          monkeypatch):
    """--husky-estimator, its default gains and --no-feed-forward reach the grid's runs
    (caught at the grid run, after the options' checks)."""
    import pipelines.control_grid as control_grid
    from terrain.control.closed_loop import default_gains

    calls = []

    def capture(*args):
        calls.append(args)
        raise _Stop()

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(control_grid, "tracked_run", RecordingRun())
    monkeypatch.setattr(control_grid, "run_grid", capture)
    assert main(["control-grid", "--vehicles", "husky", "--terrains", "ice", "--no-tune",
                 "--husky-estimator", "observer", "--no-feed-forward", "--seeds", "3",
                 "--duration-s", "1.5", "--out", "g"]) == 1
    vehicles, terrains, scenarios, seeds, gains, duration, estimators, ff, _ = calls[0]
    assert (vehicles, terrains, scenarios, seeds) == (["husky"], ["ICE"], ["straight_accel"],
                                                      [3])
    assert estimators["husky"] == "observer" and duration == 1.5 and ff is False
    assert gains == {"husky": default_gains("husky", "observer")} == {"husky": (5.0, 0.0)}


def test_control_grid_summary_names_its_seeds_and_bounds_the_straight_runs_only(
        tmp_path, monkeypatch):
    """summary.json: the evaluation seeds as given; the quasi-static slip-limit bound is
    that of the straight_accel runs on soft terrain (not the orchard's)."""
    import pipelines.control_grid as control_grid

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(control_grid, "tracked_run", RecordingRun())
    assert main(["control-grid", "--vehicles", "husky", "--terrains", "SNOW", "--scenarios",
                 "straight_accel", "orchard", "--no-tune", "--seeds", "3", "--duration-s",
                 "0.5", "--out", "g"]) == 0
    summary = json.loads((tmp_path / "g" / "summary.json").read_text())
    assert summary["evaluation_seeds"] == [3]
    assert sorted(r["scenario"] for r in summary["comparison"]) == ["orchard", "straight_accel"]
    assert [b["terrain"] for b in summary["slip_limit_bound"]] == ["SNOW"]
    runs = pd.read_csv(tmp_path / "g" / "runs.csv")
    assert sorted(runs["seed"].unique()) == [3] and len(runs) == 4


def test_stream_eval_refuses_an_infinite_switch_gap_before_reading_any_run(
        tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["stream-eval", "--part", "streams", "--switch-gap-s", "inf"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == ("terrain stream-eval: error: --switch-gap-s must be a finite number of "
                       "seconds >= 0, got inf")
    assert not any(tmp_path.iterdir())


def test_stream_eval_takes_as_many_folds_as_runs_and_logs_the_stream_settings(monkeypatch):
    """The folds and the switch gap reach the held-out streams and the MLflow parameters
    (a stand-in of three runs, caught at the first stream); a fold count the streams
    cannot be cut with (here, by the stand-in of the folds' pre-check, more folds than
    runs) is refused before them. (Which counts real runs take:
    test_stream_eval_folds_cli22_review.py.)"""
    import pipelines.stream_eval as stream_eval
    from terrain.errors import ConfigError

    calls = []

    def capture(runs, recipe, seed, smoothings, **kwargs):
        calls.append(kwargs)
        raise _Stop()

    def folds(runs, names, seed, n_splits, switch_gap_s):
        if n_splits > len(runs):
            raise ConfigError(f"{n_splits} folds over {len(runs)} split units")
        return iter(())

    monkeypatch.setattr(stream_eval, "load_dataset", lambda name: ["r0", "r1", "r2"])
    monkeypatch.setattr(stream_eval, "runs_holding", lambda runs, names: runs)
    monkeypatch.setattr(stream_eval, "held_out_folds", folds)
    monkeypatch.setattr(stream_eval, "held_out_streams", capture)
    tracking = RecordingRun()
    monkeypatch.setattr(stream_eval, "tracked_run", tracking)
    argv = ["stream-eval", "--part", "streams", "--kinds", "wheels", "--seeds", "4",
            "--switch-gap-s", "0.25"]
    assert main(argv + ["--folds", "3"]) == 1                  # reached the streams
    assert calls[-1]["n_splits"] == 3 and calls[-1]["switch_gap_s"] == 0.25
    assert tracking.starts[-1] == {"part": "streams", "seeds": "4", "switch_gap_s": 0.25,
                                   "folds": 3, "kinds": "wheels"}
    assert main(argv + ["--folds", "4"]) == 2 and len(calls) == 1
    # the wheel-cv part alone uses no recipe of --kinds: not logged as if it did
    monkeypatch.setattr(stream_eval, "window_cv", lambda *a, **k: calls.append(a) or _stop())
    assert main(["stream-eval", "--part", "wheel-cv", "--seeds", "4"]) == 1
    assert "kinds" not in tracking.starts[-1] and tracking.starts[-1]["part"] == "wheel-cv"
    # nor the held-out streams' folds and switch gap, which it does not use
    assert "folds" not in tracking.starts[-1] and "switch_gap_s" not in tracking.starts[-1]


@pytest.mark.parametrize("part", ["wheel-cv", "none"])
def test_stream_eval_refuses_the_stream_options_with_a_part_that_runs_no_stream(
        part, tmp_path, monkeypatch, capsys):
    """--folds and --switch-gap-s shape the held-out streams only: ``--part wheel-cv --folds
    3`` ran the wheel CV's fixed 5 folds and logged folds=3 to MLflow, without a word."""
    import pipelines.stream_eval as stream_eval

    monkeypatch.chdir(tmp_path)
    read = []
    monkeypatch.setattr(stream_eval, "load_dataset", lambda name: read.append(name) or [])
    extra = ["--model-out", str(tmp_path / "m")] if part == "none" else []
    for option, value in (("--folds", "3"), ("--switch-gap-s", "0.5")):
        assert main(["stream-eval", "--part", part, option, value, *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1] == (f"terrain stream-eval: error: {option} shapes the held-out "
                           f"streams; --part {part} does not run them")
    assert read == [] and not (tmp_path / "m").exists()


def _stop():
    raise _Stop()


def test_slip_fit_summary_reduces_the_medians_of_the_runs_that_did_not_slide_off():
    """Known values: the run that slid off the path is left out; each reduction is that of
    the median compensated (or gyro-compensated) error against the median plain one."""
    from pipelines.slip_fit import _summary

    errors = pd.DataFrame({"windows": ["steady_straight", "all"], "terrain": ["ICE", "ICE"],
                           "split": ["held-out seeds"] * 2, "model": ["learned"] * 2,
                           "median_abs_err": [0.02, 0.5]})
    odo = pd.DataFrame({"scenario": ["orchard"] * 3, "slid_off": [False, False, True],
                        "plain_err_pct": [4.0, 1.0, 30.0],
                        "compensated_err_pct": [1.0, 0.5, 20.0],
                        "compensated_gyro_err_pct": [2.0, 0.5, 20.0],
                        "gyro_heading_err_pct": [0.5, 0.1, 9.0],
                        "reduction_pct": [75.0, 50.0, 33.0]})
    s = _summary(errors, odo)
    assert s["held-out_seeds.learned.ICE.median_abs_err"] == 0.02    # steady windows only
    assert s["odometry.orchard.plain_err_pct"] == 2.5                   # median of 4 and 1
    assert s["odometry.orchard.compensated_err_pct"] == 0.75
    assert s["odometry.orchard.reduction_of_median_pct"] == pytest.approx(70.0)
    assert s["odometry.orchard.compensated_gyro_err_pct"] == 1.25
    assert s["odometry.orchard.gyro_reduction_of_median_pct"] == pytest.approx(50.0)
    assert s["odometry.orchard.gyro_heading_err_pct"] == pytest.approx(0.3)
    assert s["odometry.orchard.slipping_runs"] == 1.0                   # plain error > 2 %
    assert s["odometry.orchard.slipping_median_reduction_pct"] == 75.0


def test_slip_fit_takes_a_duration_of_exactly_one_slip_window(tmp_path, monkeypatch):
    # one 2 s window per run: the shortest duration with something to fit (caught at the
    # simulation, after the options' checks)
    import pipelines.slip_fit as slip_fit

    calls = []

    def capture(spec, cache_dir):
        calls.append(spec)
        raise _Stop()

    monkeypatch.setattr(slip_fit, "simulated_runs", capture)
    assert main(["slip-fit", "--terrains", "SNOW", "--scenarios", "straight_accel",
                 "--duration-s", "2", "--orchard-duration-s", "1", "--out",
                 str(tmp_path / "o"), "--cache-dir", str(tmp_path / "c")]) == 1
    assert calls[0].duration_s == 2.0


def test_audit_options_reach_its_settings_and_its_reproduce_line(tmp_path, monkeypatch):
    """Every audit option sets what it names (the shipped runs and the audit itself stood
    in for), and the report's reproduce line gives back the options that differ from the
    defaults, a threshold of 0 included (a gain of any size supports an effect)."""
    import pipelines.audit as audit

    calls = []
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(audit, "load_dataset", lambda name: [])
    monkeypatch.setattr(audit, "_audit", lambda args, runs, settings, *rest:
                        calls.append((args, settings)))
    assert main(["audit", "--dataset", "vulpi", "--json", "a.json", "--no-mlflow",
                 "--no-pooled", "--sweep-lateral-friction", "--physics", "v2",
                 "--replay-input-lowpass-hz", "2.5", "--min-gain", "0", "--seed", "7",
                 "--bootstrap", "50"]) == 0
    args, settings = calls[0]
    assert settings.pooled is False and settings.sweep_factors == audit.SWEEP_FACTORS
    assert (settings.replay.physics, settings.replay.input_cutoff_hz) == ("v2", 2.5)
    selection = settings.selection
    assert (selection.min_gain, selection.seed, selection.n_bootstrap) == (0.0, 7, 50)
    assert audit._command(args) == (
        "terrain audit --dataset vulpi --json a.json --bootstrap 50 --min-gain 0.0 --seed 7 "
        "--physics v2 --replay-input-lowpass-hz 2.5 --no-pooled --sweep-lateral-friction")
    assert main(["audit", "--dataset", "vulpi", "--json", "a.json", "--no-mlflow"]) == 0
    args, settings = calls[1]
    assert settings.pooled is True and settings.sweep_factors == ()
    assert audit._command(args) == "terrain audit --dataset vulpi --json a.json"


def test_quick_compare_refuses_threads_it_would_ignore(tmp_path, monkeypatch, capsys):
    # the quick grid's CNNs train on its own single thread
    monkeypatch.chdir(tmp_path)
    assert main(["compare", "--quick", "--threads", "2"]) == 2
    assert "would ignore ['--threads']" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("text, workers", [("-1", -1), ("-2", -2), ("1", 1), ("3", 3)])
def test_compare_n_jobs_takes_any_integer_but_zero(text, workers):
    from pipelines.compare import _n_jobs

    assert _n_jobs(text) == workers


@pytest.mark.parametrize("option, workers, backend", [
    ([], -1, ("loky", None)), (["--n-jobs", "2"], 2, ("loky", None)),
    (["--n-jobs", "1"], 1, ("loky", None)),
    (["--backend", "dask", "--address", "tcp://host:8786"], -1, ("dask", "tcp://host:8786"))])
def test_compare_n_jobs_and_backend_reach_the_grid(option, workers, backend, tmp_path,
                                                   monkeypatch):
    # --n-jobs was parsed and checked, and the grid could still run on every worker; the
    # --address must reach the backend (a local cluster otherwise, and the grid run here)
    from contextlib import contextmanager

    import pipelines.compare as compare

    cell = {"model": "svm", "signals": "all", "window_s": 2.0, "dataset": "vulpi", "seed": 0,
            "protocol": "grouped", "train_hop_s": None}
    row = {**cell, "history": 1, "accuracy": 0.9, "balanced_accuracy": 0.9, "macro_f1": 0.9,
           "run_vote_accuracy": 1.0, "fit_s_per_fold": 1.0, "infer_ms_per_window": 0.1,
           "n_windows_dropped": 0}
    asked = []

    def grid(config, n_jobs=None):
        asked.append(n_jobs)
        yield {"cell": cell, "rows": [row], "predictions": pd.DataFrame([cell]), "notes": []}

    @contextmanager
    def joblib_backend(name, address):
        asked.append((name, address))
        yield -1

    monkeypatch.setattr(compare, "iter_grid", grid)
    monkeypatch.setattr(compare, "joblib_backend", joblib_backend)
    monkeypatch.setattr(compare, "tracked_run", RecordingRun())
    monkeypatch.chdir(tmp_path)
    assert main(["compare", "--models", "svm", "--signals", "all", "--windows-s", "2",
                 "--datasets", "vulpi", "--seeds", "0", "--history", "1", "--no-progress",
                 *option, "--out", "cmp"]) == 0
    assert asked == [backend, workers]
    assert pd.read_csv(tmp_path / "cmp" / "compare_table.csv")["accuracy_mean"].tolist() == [0.9]


def test_serve_port_range_ends_at_65535():
    # 65536 reached socket.bind, whose OverflowError is no OSError: an internal error
    from pipelines.serve import bind_port
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match=r"^--port 65536 is outside 1-65535"):
        bind_port("127.0.0.1", 65536)


def test_serve_keeps_twice_its_connections_within_the_open_file_limit(tmp_path, monkeypatch,
                                                                      capsys):
    """The connections kept and as many refused ones held must fit the open-file limit
    less the server's own files: at a limit of 1000, at most (1000 - reserved) // 2."""
    import pipelines.serve as serve
    from terrain.serving.http import RESERVED_FILES

    monkeypatch.setattr(serve, "_open_file_limit", lambda: 1000)
    most = (1000 - RESERVED_FILES) // 2
    for connections in (most + 1, 1000 - RESERVED_FILES):
        assert main(["serve", "--model", str(tmp_path), "--max-connections",
                     str(connections)]) == 2
        err = capsys.readouterr().err
        assert (f"--max-connections {connections} does not fit the open-file limit 1000"
                in err and f"pass at most {most} or raise the limit" in err)
    assert main(["serve", "--model", str(tmp_path), "--max-connections", str(most)]) == 2
    assert "open-file limit" not in capsys.readouterr().err     # refused later: no model


def test_serve_listen_backlog_leaves_the_kept_and_refused_connections_their_files(
        monkeypatch):
    import pipelines.serve as serve

    monkeypatch.setattr(serve, "_open_file_limit", lambda: 1000)
    assert serve.accept_backlog(100) == (1000 - 64 - 2 * 100) // 3 == 245
    assert serve.accept_backlog(460) == 16                        # at least 16
    monkeypatch.setattr(serve, "_open_file_limit", lambda: None)
    assert serve.accept_backlog(100) == serve.MAX_BACKLOG == 2048
    monkeypatch.setattr(serve, "_open_file_limit", lambda: 10 ** 6)
    assert serve.accept_backlog(100) == 2048                      # at most MAX_BACKLOG


def test_only_a_model_of_kind_terrain_stream_counts_as_wrapped(tmp_path):
    # a `terrain train` model's MLmodel also holds metadata: it must still be wrapped
    from pipelines.serve import is_served_model

    for kind, wrapped in (("terrain-stream", True), ("terrain-classifier", False)):
        folder = tmp_path / kind
        folder.mkdir()
        (folder / "MLmodel").write_text(f"metadata:\n  kind: {kind}\n  hop_s: 0.5\n")
        assert is_served_model(folder) is wrapped
    assert is_served_model(tmp_path) is False                      # no MLmodel


def test_quick_compare_keeps_the_history_and_the_paper_protocols_windows():
    import argparse

    from pipelines.compare import add_arguments, config_from_args

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    config = config_from_args(parser.parse_args(["--quick", "--history", "1", "3"]))
    assert config.history == (1, 3) and config.windows_s == (2.0,)
    paper = config_from_args(parser.parse_args(["--quick", "--protocol", "paper"]))
    assert paper.protocol == "paper" and paper.windows_s == (1.7,)   # the papers' windows


@pytest.mark.parametrize("compare", [False, True])
def test_audit_logs_whether_it_compared_the_physics_versions(compare, tmp_path, monkeypatch):
    """``--compare-physics`` replays every run twice more and adds the v1/v2 gain table to
    the report; its MLflow run did not say it had (no parameter of it among the settings)."""
    import pipelines.audit as audit

    monkeypatch.setattr(audit, "load_dataset", lambda name: [])
    monkeypatch.setattr(audit, "_audit", lambda *args: None)
    recording = RecordingRun()
    monkeypatch.setattr(audit, "tracked_run", recording)
    argv = ["audit", "--dataset", "vulpi", "--json", str(tmp_path / "a.json")]
    assert main(argv + ["--compare-physics"] * compare) == 0
    assert recording.starts[-1]["compare_physics"] is compare
    assert recording.starts[-1]["dataset"] == "vulpi"


def test_stream_eval_part_none_refuses_seeds_and_logs_none(tmp_path, monkeypatch, capsys):
    """``--part none`` only fits and saves the --model-out models, on every run, seedless:
    ``--part none --seeds 7`` was taken and logged to MLflow as seeds=7 (and without
    --seeds the unused default seeds=0,1,2)."""
    import pipelines.stream_eval as stream_eval

    monkeypatch.chdir(tmp_path)
    read = []
    monkeypatch.setattr(stream_eval, "load_dataset", lambda name: read.append(name) or [])
    argv = ["stream-eval", "--part", "none", "--kinds", "wheels",
            "--model-out", str(tmp_path / "m")]
    assert main(argv + ["--seeds", "7"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "terrain stream-eval: error: --seeds seed the wheel CV and the held-out streams; "
        "--part none runs neither")
    assert read == []
    recording = RecordingRun()
    monkeypatch.setattr(stream_eval, "tracked_run", recording)
    monkeypatch.setattr(stream_eval, "fit_stream_model", lambda recipe, runs: _stop())
    assert main(argv) == 1                     # reached the fit (the stand-in stops there)
    assert recording.starts[-1] == {"part": "none", "kinds": "wheels"}
    # elsewhere the default seeds are 0 1 2, and logged
    monkeypatch.setattr(stream_eval, "window_cv", lambda runs, recipe, hop, seeds, s:
                        read.append(seeds) or _stop())
    assert main(["stream-eval", "--part", "wheel-cv"]) == 1
    assert read[-1] == [0, 1, 2] and recording.starts[-1]["seeds"] == "0,1,2"
