"""``terrain stream`` on measured-layout files, for a wheel-only and an IMU + wheel model."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

import pipelines.stream as stream_pipeline
from terrain.cli import main
from terrain.serving.pyfunc import save_model
from terrain.serving import load_stream_model

COLUMNS_TAIL = ["target_slip_traction", "target_slip_braking", "target_slip_steady",
                "window_age_s", "flags"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, borealtc_runs, train_runs):
    """An unseen SNOW run written back to the CSV layout: <root>/SNOW/{imu,pro}_07.csv."""
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.terrain == "SNOW" and r.has_imu
               and r.run_id not in seen and r.duration_s > 30)
    folder = tmp_path_factory.mktemp("runs") / "SNOW"
    folder.mkdir()
    w = run.streams["wheels"].rename(columns={"t_s": "time", "vel_l": "velL", "vel_r": "velR",
                                              "cur_l": "curL", "cur_r": "curR"})
    w[["time", "curL", "curR", "velL", "velR"]].to_csv(folder / "pro_07.csv", index=False)
    run.streams["imu"].rename(columns={"t_s": "time"}).to_csv(folder / "imu_07.csv",
                                                              index=False)
    return folder


def _saved(model, path):
    save_model(path, model.pipeline, model.channels, model.window, list(model.classes),
               {"dataset": "borealtc-test"}, progress=False)
    loaded = load_stream_model(path)
    assert loaded.channels == model.channels and loaded.classes == model.classes
    return path


@pytest.mark.parametrize("kind", ["wheel_model", "all_model"])
def test_stream_writes_one_decision_per_hop_with_the_issue_columns(kind, request, run_dir,
                                                                   tmp_path, capsys,
                                                                   monkeypatch):
    monkeypatch.chdir(tmp_path)
    model = request.getfixturevalue(kind)
    model_dir = _saved(model, tmp_path / "model")
    out = tmp_path / "decisions.csv"
    assert main(["stream", "--model", str(model_dir), str(run_dir), "--out", str(out),
                 "--hop-s", "1.0"]) == 0
    frame = pd.read_csv(out, keep_default_na=False)
    assert list(frame.columns) == (["t_s", "terrain", "confidence"]
                                   + [f"proba_{c}" for c in model.classes] + COLUMNS_TAIL)
    assert len(frame) > 20 and (frame["t_s"].diff().dropna().round(9) == 1.0).all()
    assert set(frame["terrain"]) <= set(model.classes)
    printed = capsys.readouterr().out
    assert "decisions every 1.0 s" in printed and "SNOW" in printed


def test_stream_errors_are_typed_messages(run_dir, tmp_path, capsys, all_model, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["stream", "--model", str(tmp_path), str(run_dir), "--out",
                 str(tmp_path / "d.csv")]) == 2
    assert "not a terrain model directory" in capsys.readouterr().err
    wheel_only = tmp_path / "runs" / "SNOW"
    wheel_only.mkdir(parents=True)
    (wheel_only / "pro_07.csv").write_text((run_dir / "pro_07.csv").read_text())
    model_dir = _saved(all_model, tmp_path / "model")
    assert main(["stream", "--model", str(model_dir), str(wheel_only), "--out",
                 str(tmp_path / "d.csv")]) == 2
    assert "needs stream(s) ['imu']" in capsys.readouterr().err


def _edited_copy(run_dir, root, edit_pro=None, edit_imu=None):
    """Copy of the run's folder under ``root``/SNOW with its files edited (frames of file
    column names)."""
    folder = root / "SNOW"
    folder.mkdir(parents=True)
    for name, edit in (("pro_07.csv", edit_pro), ("imu_07.csv", edit_imu)):
        frame = pd.read_csv(run_dir / name)
        (edit(frame) if edit else frame).to_csv(folder / name, index=False)
    return folder


def _stream(model_dir, folder, out):
    return main(["stream", "--model", str(model_dir), str(folder), "--out", str(out),
                 "--hop-s", "1.0"])


def test_stream_errors_name_the_run_folder_given(tmp_path, capsys, wheel_model, monkeypatch):
    monkeypatch.chdir(tmp_path)
    model_dir = _saved(wheel_model, tmp_path / "model")
    (tmp_path / "cases" / "EMPTY").mkdir(parents=True)
    assert _stream(model_dir, "cases/NOPE", "d.csv") == 2
    err = capsys.readouterr().err
    assert "run folder cases/NOPE does not exist" in err and "(file" not in err
    assert _stream(model_dir, "cases/EMPTY", "d.csv") == 2
    assert "cases/EMPTY holds no run files" in capsys.readouterr().err


def test_stream_names_a_run_of_another_vehicle_than_the_models(run_dir, tmp_path, capsys,
                                                               wheel_model, monkeypatch):
    # a Husky model (dataset borealtc, no vehicle key: a model saved before train wrote one)
    # on a run whose meta_XX.json names the tracked vehicle: decided, and said
    monkeypatch.chdir(tmp_path)
    model_dir = tmp_path / "model"
    save_model(model_dir, wheel_model.pipeline, wheel_model.channels, wheel_model.window,
               list(wheel_model.classes), {"dataset": "borealtc"}, progress=False)
    folder = _edited_copy(run_dir, tmp_path / "runs")
    assert _stream(model_dir, folder, tmp_path / "d.csv") == 0
    assert "another vehicle" not in capsys.readouterr().out      # no meta: the Husky
    (folder / "meta_07.json").write_text('{"vehicle": "tracked"}')
    assert _stream(model_dir, folder, tmp_path / "d.csv") == 0
    out = capsys.readouterr().out
    assert ("note: run SNOW/07 was recorded by vehicle 'tracked' (its meta_XX.json), the "
            "model was trained on 'husky' runs (dataset borealtc)") in out
    assert len(pd.read_csv(tmp_path / "d.csv")) > 20


@pytest.mark.slow
def test_stream_and_predict_name_an_imu_slower_than_the_models_windows(
        run_dir, tmp_path, capsys, all_model, wheel_model, monkeypatch):
    # a 50 Hz IMU before a 100 Hz model was interpolated up without a word (CLI fuzz);
    # here the fixture's 50 Hz model and the run's 100 Hz IMU kept every 4th sample
    monkeypatch.chdir(tmp_path)
    model_dir = _saved(all_model, tmp_path / "model")
    assert all_model.window.rate_hz == 50.0
    note = "IMU is sampled at 25 Hz, the model's windows at 50 Hz"
    assert _stream(model_dir, run_dir, tmp_path / "d.csv") == 0
    assert "is sampled at" not in capsys.readouterr().out           # the run's own 100 Hz
    folder = _edited_copy(run_dir, tmp_path / "runs", edit_imu=lambda f: f.iloc[::4])
    assert _stream(model_dir, folder, tmp_path / "d.csv") == 0
    out = capsys.readouterr().out
    assert f"note: run SNOW/07's {note}" in out and "nothing above 12.5 Hz" in out
    assert main(["predict", "--model", str(model_dir), str(folder.parent), "--out",
                 str(tmp_path / "p.csv"), "--no-progress"]) == 0
    assert note in capsys.readouterr().out
    # a wheel-only model reads no IMU channel: nothing to say
    wheels_dir = _saved(wheel_model, tmp_path / "wheels")
    assert _stream(wheels_dir, folder, tmp_path / "d.csv") == 0
    assert "is sampled at" not in capsys.readouterr().out


def test_model_vehicle_reads_the_key_else_the_shipped_dataset():
    from terrain.serving.model import model_vehicle, other_vehicle_note
    assert model_vehicle({"vehicle": "Tracked", "dataset": "borealtc"}) == "tracked"
    assert [model_vehicle({"dataset": d}) for d in ("borealtc", "vulpi", "combined")] == \
        ["husky"] * 3
    assert model_vehicle({"dataset": "sim"}) is None and model_vehicle({}) is None
    assert model_vehicle({"vehicle": None, "dataset": "vulpi"}) == "husky"
    assert other_vehicle_note({}, "tracked", "r") is None
    assert other_vehicle_note({"dataset": "vulpi"}, "HUSKY", "r") is None


def test_stream_reports_the_cells_the_reader_repaired(run_dir, tmp_path, capsys, wheel_model,
                                                      monkeypatch):
    monkeypatch.chdir(tmp_path)
    model_dir = _saved(wheel_model, tmp_path / "model")

    def one_nan(frame):
        frame.loc[40, "curL"] = float("nan")
        return frame

    folder = _edited_copy(run_dir, tmp_path / "runs", edit_pro=one_nan)
    assert _stream(model_dir, folder, tmp_path / "d.csv") == 0
    out = capsys.readouterr().out
    assert "repaired 1 isolated non-finite cell(s) by linear interpolation" in out
    assert "wheels.cur_l:1" in out


def _model_and_dead_current_run(run_dir, tmp_path, wheel_model, monkeypatch):
    """Working in ``tmp_path``: the wheel model's saved folder and a copy of the run whose
    left current sensor is dead for 22 s (the stuck rule needs 20 s)."""
    def dead_current(frame):
        frame.loc[(frame["time"] > 5.0) & (frame["time"] < 27.0), "curL"] = 3.25
        return frame

    monkeypatch.chdir(tmp_path)
    return (_saved(wheel_model, tmp_path / "model"),
            _edited_copy(run_dir, tmp_path / "runs", edit_pro=dead_current))


def test_stream_flags_decisions_whose_window_holds_a_stuck_sensor(run_dir, tmp_path, capsys,
                                                                  wheel_model, monkeypatch):
    model_dir, folder = _model_and_dead_current_run(run_dir, tmp_path, wheel_model,
                                                    monkeypatch)
    out_csv = tmp_path / "d.csv"
    assert _stream(model_dir, folder, out_csv) == 0
    captured = capsys.readouterr()
    assert "column 'curL' (wheels.cur_l) stuck at one value" in captured.err
    frame = pd.read_csv(out_csv, keep_default_na=False)
    has = frame["flags"].str.contains("stuck:wheels.cur_l")
    pro = pd.read_csv(folder / "pro_07.csv")
    a, b = pro.loc[pro["curL"] == 3.25, "time"].agg(["min", "max"])  # the stuck samples
    end = frame["t_s"] - frame["window_age_s"]      # each decision's window [end - 2 s, end)
    overlaps = (end - 2.0 <= b) & (end > a)
    assert has.sum() > 15 and (has == overlaps).all()
    n = int(has.sum())
    assert f"stuck or dead sensor channel(s): SNOW/07 (wheels.cur_l); {n} window(s)" \
        in captured.out
    assert f"stuck {n}" in captured.out and f"{int((frame['flags'] != '').sum())} flagged" \
        in captured.out


def test_stream_says_why_a_run_shorter_than_a_window_gives_no_decision(
        run_dir, tmp_path, capsys, wheel_model, monkeypatch):
    monkeypatch.chdir(tmp_path)
    model_dir = _saved(wheel_model, tmp_path / "model")
    head = (lambda f: f[f["time"] < 1.5])
    folder = _edited_copy(run_dir, tmp_path / "runs", edit_pro=head, edit_imu=head)
    capsys.readouterr()
    assert _stream(model_dir, folder, tmp_path / "d.csv") == 2
    captured = capsys.readouterr()
    assert "1 run(s) too short (shorter than one 2 s window): SNOW/07" in captured.out
    err = captured.err.strip()
    assert len(err.splitlines()) == 1
    assert re.search(r"streams \['wheels'\] overlap for 1\.\d\d s, shorter than the model's "
                     r"2 s window", err) and str(folder) in err
    assert not (tmp_path / "d.csv").exists()


def test_stream_says_which_samples_were_refused_when_long_streams_give_no_decision(
        run_dir, tmp_path, capsys, wheel_model, monkeypatch):
    """Streams that overlap for many windows but whose samples the service's input rules
    all refuse: the message counts the refusals instead of claiming a short overlap."""
    def refuse_all(channels, t_s, values, last_t_s):
        return np.zeros(len(t_s), dtype=bool), "implausible_rate"

    real = stream_pipeline.StreamService
    monkeypatch.setattr(stream_pipeline, "StreamService",
                        lambda *a, **k: real(*a, rules=(refuse_all,), **k))
    monkeypatch.chdir(tmp_path)
    model_dir = _saved(wheel_model, tmp_path / "model")
    capsys.readouterr()
    assert _stream(model_dir, run_dir, tmp_path / "d.csv") == 2
    err = capsys.readouterr().err.strip()
    n_wheels = len(pd.read_csv(run_dir / "pro_07.csv"))
    assert len(err.splitlines()) == 1 and "shorter than" not in err
    assert re.search(r"overlap for \d+\.\d\d s \(window 2 s\), but the service's input rules "
                     rf"left too few samples; refused: {n_wheels} of stream wheels "
                     r"\(implausible_rate\)", err), err
    assert not (tmp_path / "d.csv").exists()


def test_stream_refuses_a_run_whose_wheel_file_is_shorter_than_a_window_beside_a_full_imu(
        run_dir, tmp_path, capsys, all_model, monkeypatch):
    # the IMU alone fills windows, so the service emits decisions flagged short/stale; a
    # replay of the run is still refused: its streams share less than one window
    monkeypatch.chdir(tmp_path)
    model_dir = _saved(all_model, tmp_path / "model")
    folder = _edited_copy(run_dir, tmp_path / "runs", edit_pro=lambda f: f[f["time"] < 0.5])
    capsys.readouterr()
    assert _stream(model_dir, folder, tmp_path / "d.csv") == 2
    captured = capsys.readouterr()
    assert "1 run(s) too short" in captured.out and "1 plausibility warning" in captured.out
    assert "rule clock_overlap" in captured.err and "left out: imu" in captured.err
    assert re.search(r"overlap for 0\.\d\d s, shorter than the model's 2 s window",
                     captured.err)
    assert not (tmp_path / "d.csv").exists()


def test_timestamp_errors_print_plain_numbers(run_dir, tmp_path, capsys, wheel_model,
                                              monkeypatch):
    monkeypatch.chdir(tmp_path)
    model_dir = _saved(wheel_model, tmp_path / "model")

    def duplicate(frame):
        frame.loc[30, "time"] = frame.loc[29, "time"]
        return frame

    folder = _edited_copy(run_dir, tmp_path / "runs", edit_pro=duplicate)
    t = float(pd.read_csv(folder / "pro_07.csv")["time"].iloc[29])
    assert _stream(model_dir, folder, tmp_path / "d.csv") == 2
    err = capsys.readouterr().err
    assert f"duplicated timestamp {t!r} after {t!r} (1 such row(s), at line 32)" in err
    assert "np." not in err and "pro_07.csv" in err


@pytest.mark.slow
def test_stream_reset_options_reach_the_filter(run_dir, tmp_path, capsys, wheel_model,
                                               monkeypatch):
    # the reset at a confidence every window reaches decides each window's own class: the
    # same decisions as no smoothing; an impossible confidence changes nothing
    monkeypatch.chdir(tmp_path)
    model_dir = _saved(wheel_model, tmp_path / "model")
    frames = {}
    for name, extra in {"raw": ["--dwell-s", "0"], "filter": [],
                        "reset_any": ["--reset-confidence", "1e-9", "--reset-windows", "1"],
                        "reset_never": ["--reset-confidence", "1.0"]}.items():
        out = tmp_path / f"{name}.csv"
        assert main(["stream", "--model", str(model_dir), str(run_dir), "--out", str(out),
                     *extra]) == 0
        frames[name] = pd.read_csv(out, keep_default_na=False)
    assert (frames["reset_any"]["terrain"] == frames["raw"]["terrain"]).all()
    assert (frames["reset_never"]["terrain"] == frames["filter"]["terrain"]).all()
    assert (frames["filter"]["terrain"] != frames["raw"]["terrain"]).any()
    capsys.readouterr()
    for extra, words in ((["--reset-confidence", "1.5"],
                          "argument --reset-confidence: must be a probability in [0, 1]"),
                         (["--reset-confidence", "0"], "--reset-confidence must be > 0"),
                         (["--min-confidence", "2"],
                          "argument --min-confidence: must be a probability in [0, 1]"),
                         (["--reset-confidence", "0.9", "--dwell-s", "0"],
                          "--dwell-s 0 turns off"),
                         (["--dwell-s", "inf"], "--dwell-s must be a finite number >= 0"),
                         (["--reset-confidence", "0.9", "--reset-windows", "0"],
                          "argument --reset-windows: must be an integer >= 1"),
                         (["--hop-s", "0"], "argument --hop-s: must be a finite number > 0"),
                         # a count alone changed nothing (the reset is off) and said nothing
                         (["--reset-windows", "3"], "--reset-windows 3 needs "
                                                    "--reset-confidence")):
        try:
            code = main(["stream", "--model", str(model_dir), str(run_dir), "--out",
                         str(tmp_path / "bad.csv"), *extra])
        except SystemExit as exc:     # argparse's own usage error (an option's type)
            code = exc.code
        assert code == 2
        err = capsys.readouterr().err
        assert words in err and "Traceback" not in err


def test_replay_recorded_reports_what_the_service_did(borealtc_runs, train_runs, wheel_model,
                                                      all_model):
    """The library side of ``terrain stream``: overlap, label share and refusals."""
    from dataclasses import replace

    from terrain.errors import ConfigError, DataFormatError
    from terrain.serving import StreamConfig, StreamService, TableTargets
    from terrain.serving.replay import replay_recorded

    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.has_imu and r.run_id not in seen
               and r.duration_s > 30)
    wheels = run.streams["wheels"]["t_s"]
    replay = replay_recorded(StreamService(wheel_model, TableTargets(wheel_model.classes),
                                           StreamConfig(hop_s=1.0)), run)
    assert replay.overlap_s == pytest.approx(wheels.iloc[-1] - wheels.iloc[0])
    assert not replay.too_short and replay.streams == ("wheels",)
    replay.check(".")                                   # decisions: nothing raised
    share = float((replay.frame["terrain"] == run.terrain).mean())
    lines = replay.summary("d.csv").splitlines()
    assert lines[0].startswith(f"{run.run_id}: {len(replay.frame)} decisions every 1.0 s")
    assert lines[1] == (f"  decided {run.terrain} (the folder's label) in {share:.3f} of "
                        "the decisions")
    # the same replay with no decision: the refusals are named, not a short overlap
    empty = replace(replay, frame=replay.frame.iloc[:0], refused={("wheels", "duplicate"): 7})
    with pytest.raises(DataFormatError, match=r"refused: 7 of stream wheels \(duplicate\)"):
        empty.check(".")
    one = replace(replay, frame=replay.frame.iloc[:1])
    assert one.summary("d.csv").startswith(f"{run.run_id}: 1 decision every 1.0 s from")
    # an IMU + wheel model cannot replay the wheels alone
    wheel_only = replace(run, streams={"wheels": run.streams["wheels"]})
    with pytest.raises(ConfigError, match=r"needs stream\(s\) \['imu'\], absent from run"):
        replay_recorded(StreamService(all_model, TableTargets(all_model.classes)), wheel_only)


@pytest.mark.parametrize("min_confidence", [0.95, 0.2])
def test_stream_min_confidence_sets_when_the_fallback_target_is_used(
        min_confidence, run_dir, tmp_path, capsys, wheel_model, monkeypatch):
    # below --min-confidence a decision takes the table's conservative entry, at or above
    # it the decided class's own targets, whatever the built-in default (0.5)
    from terrain.control import DesiredSlipConfig
    from terrain.serving import TableTargets

    monkeypatch.chdir(tmp_path)
    model_dir = _saved(wheel_model, tmp_path / "model")
    out = tmp_path / "d.csv"
    assert main(["stream", "--model", str(model_dir), str(run_dir), "--out", str(out),
                 "--min-confidence", str(min_confidence)]) == 0
    frame = pd.read_csv(out, keep_default_na=False)
    table = TableTargets(wheel_model.classes, DesiredSlipConfig())
    fallback = table.target_for(None, 1.0, False)
    fresh = frame[frame["flags"].isin(["", "low_confidence"])]
    assert ((fresh["flags"] == "low_confidence") == (fresh["confidence"] < min_confidence)).all()
    near = (fresh["confidence"] - 0.5).abs() < abs(min_confidence - 0.5)
    band = fresh[near & ((fresh["confidence"] < 0.5) == (min_confidence < 0.5))]
    assert len(band) > 0        # decisions the default threshold would treat otherwise
    for row in fresh.itertuples():
        want = (fallback if row.confidence < min_confidence
                else table.target_for(row.terrain, 1.0, False))
        assert row.target_slip_traction == pytest.approx(want.traction, abs=1e-9)
        assert row.target_slip_braking == pytest.approx(want.braking, abs=1e-9)


@pytest.mark.slow
def test_predict_counts_the_windows_holding_a_stuck_sensor(run_dir, tmp_path, capsys,
                                                           wheel_model, monkeypatch):
    # predict flags each window holding the stuck channel and its input report counts them
    model_dir, folder = _model_and_dead_current_run(run_dir, tmp_path, wheel_model,
                                                    monkeypatch)
    out_csv = tmp_path / "p.csv"
    assert main(["predict", "--model", str(model_dir), str(folder), "--out", str(out_csv),
                 "--no-progress"]) == 0
    frame = pd.read_csv(out_csv, keep_default_na=False)
    n = int((frame["flags"] != "").sum())
    assert n > 5 and (frame["flags"][frame["flags"] != ""] == "stuck:wheels.cur_l").all()
    assert (f"stuck or dead sensor channel(s): runs/SNOW/07 (wheels.cur_l); {n} window(s) "
            "holding one flagged") in capsys.readouterr().out
