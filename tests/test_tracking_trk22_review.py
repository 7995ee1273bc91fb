"""Review trk22: what a tracked run is tagged with equals what it is parametrised with."""

from __future__ import annotations

import mlflow
import pytest

from terrain.errors import ConfigError
from terrain.tracking import code_version, tracked_run, tracking_uri


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


def _runs(name):
    client = mlflow.MlflowClient(tracking_uri=tracking_uri())
    exp = client.get_experiment_by_name(name)
    return [] if exp is None else client.search_runs([exp.experiment_id])


@pytest.mark.slow
@pytest.mark.parametrize("where", ["tags", "params"])
def test_a_caller_code_version_is_refused_before_any_run(store, where):
    # tags={"code_version": "mine"} tagged the run 'mine' while its code_version parameter
    # stayed the commit (and params= the other way round): one run, two code versions
    kwargs = {where: {"code_version": "mine"}}
    with pytest.raises(ConfigError, match=f"code_version.*{where}"):
        with tracked_run("trk22-cv", announce=False, **kwargs):
            pass
    assert _runs("trk22-cv") == []


@pytest.mark.slow
def test_tag_and_param_code_version_agree(store):
    with tracked_run("trk22-ok", announce=False, tags={"note": "x"},
                     params={"alpha": 1}) as run:
        pass
    logged = mlflow.MlflowClient(tracking_uri=tracking_uri()).get_run(run.run_id)
    assert logged.data.tags["code_version"] == logged.data.params["code_version"] \
        == code_version()
    assert logged.data.tags["note"] == "x" and logged.data.params["alpha"] == "1"


@pytest.mark.slow
def test_non_finite_metrics_beyond_the_tag_limit_are_all_listed(store):
    # 600 non-finite metrics listed 20,000 characters: MLflow cut the tag to 8,000 (a name
    # cut in half at its end, the rest lost) and a later call merged that cut name back
    from mlflow.utils.validation import MAX_TAG_VAL_LENGTH

    from terrain.tracking import TAG_LIMIT

    assert TAG_LIMIT == MAX_TAG_VAL_LENGTH
    first = {f"online.SNOW.wz.held-out.gain_{i:04d}": float("nan") for i in range(600)}
    with tracked_run("trk22-nf", announce=False) as run:
        run.log_metrics({**first, "ok": 1.0})
        run.log_metrics({"zz_last": float("inf")})
    client = mlflow.MlflowClient(tracking_uri=tracking_uri())
    logged = client.get_run(run.run_id)
    tag = logged.data.tags["non_finite_metrics"]
    assert len(tag) <= MAX_TAG_VAL_LENGTH
    every = sorted([*first, "zz_last"])
    listed, _, rest = tag.partition(",...")
    assert listed.split(",") == every[:len(listed.split(","))]      # whole names, in order
    assert rest == f" {len(every) - len(listed.split(','))} more in non_finite_metrics.txt"
    path = client.download_artifacts(run.run_id, "non_finite_metrics.txt", str(store))
    with open(path) as f:
        assert f.read().splitlines() == every
    assert logged.data.metrics == {"ok": 1.0}


@pytest.mark.slow
def test_a_second_handle_on_the_run_keeps_the_names_the_tag_lists(store):
    # the names of earlier calls come from the tag, not only from the handle's memory
    from terrain.tracking import TrackedRun

    with tracked_run("trk22-nf2", announce=False) as run:
        run.log_metrics({"b": float("nan")})
        other = TrackedRun(run.run_id, run.experiment, run.uri, run.client)
        other.log_metrics({"a": float("-inf")})
    tags = mlflow.MlflowClient(tracking_uri=tracking_uri()).get_run(run.run_id).data.tags
    assert tags["non_finite_metrics"] == "a,b"


@pytest.mark.slow
def test_a_parameter_longer_than_mlflow_keeps_is_kept_whole_in_a_file(store):
    # a 6,999-character value was cut to 6,000 by MLflow with only a log warning: the run's
    # parameter was not the value it ran with, and nothing said so in the run
    from mlflow.utils.validation import MAX_PARAM_VAL_LENGTH

    from terrain.tracking import PARAM_LIMIT

    assert PARAM_LIMIT == MAX_PARAM_VAL_LENGTH
    value = ",".join(f"run_{i:05d}" for i in range(700))        # 6,999 characters
    with tracked_run("trk22-long", announce=False, params={"runs": value, "short": 1}) as run:
        pass
    client = mlflow.MlflowClient(tracking_uri=tracking_uri())
    params = client.get_run(run.run_id).data.params
    assert params["short"] == "1"
    assert len(params["runs"]) <= PARAM_LIMIT
    head, _, note = params["runs"].partition("...")
    assert value.startswith(head) and note == " (6999 characters in params/runs.txt)" \
        or pytest.fail(params["runs"][-80:])
    path = client.download_artifacts(run.run_id, "params/runs.txt", str(store))
    with open(path) as f:
        assert f.read() == value
