"""What ``terrain control-sim`` leaves behind when its trace table fails: the earlier JSON
and CSV whole, not a new JSON beside an earlier (or half-written) trace (a short run, the
failure simulated with monkeypatch)."""

from __future__ import annotations

import pipelines.control_sim as control_sim
from terrain.cli import main


def _control_sim(tmp_path) -> int:
    return main(["control-sim", "--vehicle", "husky", "--terrain", "ice", "--scenario",
                 "straight_accel", "--controller", "off", "--duration-s", "0.5",
                 "--terrain-source", "label",   # (the classifier is not what is tested)
                 "--json", str(tmp_path / "c.json"), "--csv", str(tmp_path / "c.csv")])


def test_a_trace_that_fails_leaves_the_earlier_json_and_csv(tmp_path, monkeypatch):
    (tmp_path / "c.json").write_text('{"earlier": true}\n')
    (tmp_path / "c.csv").write_text("t_s\n0\n")

    def fails(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(control_sim, "trace_frame", fails)
    assert _control_sim(tmp_path) != 0
    assert (tmp_path / "c.json").read_text() == '{"earlier": true}\n'
    assert (tmp_path / "c.csv").read_text() == "t_s\n0\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.csv", "c.json"]


def test_a_run_writes_both(tmp_path):
    assert _control_sim(tmp_path) == 0
    assert (tmp_path / "c.json").read_text().startswith("{")
    assert (tmp_path / "c.csv").read_text().startswith("t_s")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.csv", "c.json"]
