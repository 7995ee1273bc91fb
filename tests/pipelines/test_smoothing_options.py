"""The forward filter's options of ``terrain stream`` and ``terrain serve`` map onto
:class:`SmoothingConfig`: the defaults are the filter's own, each option reaches its field."""

from __future__ import annotations

import pytest

from pipelines.arguments import smoothing_from_args
from terrain.cli import build_parser
from terrain.serving.smoothing import SmoothingConfig


def _smoothing(tmp_path, monkeypatch, *extra):
    monkeypatch.chdir(tmp_path)
    args = build_parser().parse_args(["stream", "--model", "m", "r", "--out", "d.csv", *extra])
    return smoothing_from_args(args)


def test_default_options_give_the_filters_documented_defaults(tmp_path, monkeypatch):
    # docs/streaming.md: a 10 s dwell, no reset; `stream` and `serve` share these options
    config = _smoothing(tmp_path, monkeypatch)
    assert config == SmoothingConfig()
    assert config.dwell_s == 10.0 and config.reset_confidence is None
    assert config.reset_windows == 2


@pytest.mark.parametrize("extra, fields", [
    (["--dwell-s", "0"], {"dwell_s": None}),
    (["--dwell-s", "3.5"], {"dwell_s": 3.5}),
    (["--reset-confidence", "0.8"], {"reset_confidence": 0.8, "reset_windows": 2}),
    (["--reset-confidence", "0.8", "--reset-windows", "4"],
     {"reset_confidence": 0.8, "reset_windows": 4}),
])
def test_each_option_reaches_its_field(extra, fields, tmp_path, monkeypatch):
    config = _smoothing(tmp_path, monkeypatch, *extra)
    assert {k: getattr(config, k) for k in fields} == fields
