"""The options of ``terrain cv`` and ``terrain train`` reach the experiment configuration:
no option silently ignored, each default the documented one (checked without any data)."""

from __future__ import annotations

import pytest

import pipelines.train as train
from pipelines.cv import config_from_args
from terrain.cli import build_parser, main
from terrain.errors import ConfigError


def _cv(*argv):
    return config_from_args(build_parser().parse_args(["cv", *argv]))


@pytest.mark.parametrize("protocol, seeds", [("grouped", (0, 1, 2)), ("loro", (0,)),
                                             ("paper", (0,))])
def test_cv_default_seeds_per_protocol(protocol, seeds):
    # leave-one-run-out is deterministic and the paper's split is seed 0: one seed each
    assert _cv("--protocol", protocol).seeds == seeds
    assert _cv("--protocol", protocol, "--seeds", "4", "5").seeds == (4, 5)


def test_cv_options_reach_the_config():
    config = _cv("--window-s", "1.5", "--hop-s", "0.5", "--train-hop-s", "0.25",
                 "--steady-only", "--search", "--signals", "imu", "--model", "svm")
    assert (config.window_s, config.hop_s, config.train_hop_s) == (1.5, 0.5, 0.25)
    assert config.steady_only and config.search and config.signals == ("imu",)
    default = _cv()
    assert (default.window_s, default.hop_s, default.train_hop_s) == (2.0, None, None)
    assert not default.steady_only and default.signals == ("all",) and default.model == "svm"


class _Stop(ConfigError):
    """Raised by the stand-in configuration: stops ``train`` before any data is read."""


@pytest.fixture
def train_config(monkeypatch):
    """The keyword arguments ``terrain train ARGV`` builds its configuration from."""
    seen = {}

    def capture(**kwargs):
        seen.update(kwargs)
        raise _Stop("stop")

    monkeypatch.setattr(train, "ExperimentConfig", capture)

    def run(*argv):
        seen.clear()
        assert main(["train", *argv]) == 2
        return dict(seen)
    return run


def test_train_defaults_per_dataset(train_config, capsys):
    # README / docs/model_comparison.csv: BorealTC's best model without the forward wheel
    # speeds, fitted on windows every 0.5 s; Vulpi's SVM on all signals, non-overlapping
    boreal = train_config("--dataset", "borealtc")
    assert (boreal["model"], boreal["signals"], boreal["train_hop_s"]) == (
        "ensemble", ("all-no-speed",), 0.5)
    vulpi = train_config("--dataset", "vulpi")
    assert (vulpi["model"], vulpi["signals"], vulpi["train_hop_s"]) == ("svm", ("all",), None)
    combined = train_config("--dataset", "combined")
    assert combined["model"] == "ensemble3" and combined["train_hop_s"] is None


def test_train_options_reach_the_config(train_config, capsys):
    given = train_config("--dataset", "borealtc", "--model", "svm", "--signals", "imu",
                         "--window-s", "1.5", "--train-hop-s", "0.75", "--cnn-seeds", "3",
                         "--run-balanced", "--search")
    assert (given["model"], given["signals"], given["window_s"], given["train_hop_s"]) == (
        "svm", ("imu",), 1.5, 0.75)
    assert given["cnn_seeds"] == 3 and given["run_balanced"] and given["search"]
    assert given["seeds"] == (0,) and not given["window_ekf"]


@pytest.mark.parametrize("protocol, headline", [("grouped", True), ("loro", True),
                                                ("paper", False)])
def test_cv_report_marks_only_the_leaky_protocol_as_not_headline(protocol, headline):
    from types import SimpleNamespace

    import pandas as pd

    from pipelines.cv import result_dict

    config = _cv("--protocol", protocol)
    pooled = pd.DataFrame({"seed": [0, 1], "accuracy": [0.8, 0.9]})
    report = SimpleNamespace(classes=["ICE", "SNOW"], summary=lambda: {}, pooled=pooled,
                             confusion=pd.DataFrame([[3, 1], [0, 4]]), notes=[])
    result = SimpleNamespace(config=config, report=report, n_windows=8, n_runs=2,
                             timings_s={})
    got = result_dict(result)
    assert got["headline"] is headline
    # the spread over seeds is the population one (ddof 0), as printed
    assert got["pooled"] == {"accuracy": {"mean": pytest.approx(0.85),
                                          "std": pytest.approx(0.05)}}
    assert got["confusion"] == {"labels": ["ICE", "SNOW"], "counts": [[3, 1], [0, 4]]}
