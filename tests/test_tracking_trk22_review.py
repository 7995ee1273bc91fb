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


@pytest.mark.parametrize("where", ["tags", "params"])
def test_a_caller_code_version_is_refused_before_any_run(store, where):
    # tags={"code_version": "mine"} tagged the run 'mine' while its code_version parameter
    # stayed the commit (and params= the other way round): one run, two code versions
    kwargs = {where: {"code_version": "mine"}}
    with pytest.raises(ConfigError, match=f"code_version.*{where}"):
        with tracked_run("trk22-cv", announce=False, **kwargs):
            pass
    assert _runs("trk22-cv") == []


def test_tag_and_param_code_version_agree(store):
    with tracked_run("trk22-ok", announce=False, tags={"note": "x"},
                     params={"alpha": 1}) as run:
        pass
    logged = mlflow.MlflowClient(tracking_uri=tracking_uri()).get_run(run.run_id)
    assert logged.data.tags["code_version"] == logged.data.params["code_version"] \
        == code_version()
    assert logged.data.tags["note"] == "x" and logged.data.params["alpha"] == "1"
