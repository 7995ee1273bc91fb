"""``terrain control-sim``'s JSON output is standard JSON whatever the metrics hold."""

from __future__ import annotations

import json
import math

import pipelines.control_sim as control_sim
from terrain.cli import main


def _strict_loads(text: str):
    """Parse ``text`` as RFC 8259 JSON: the bare tokens NaN / Infinity are refused."""
    def refuse(token):
        raise ValueError(f"non-standard JSON token {token}")
    return json.loads(text, parse_constant=refuse)


def test_control_sim_writes_a_non_finite_metric_as_null(tmp_path, monkeypatch, capsys):
    """A metric that could not be computed (NaN: e.g. a slip of a wheel the simulator left
    undefined) was written by ``json.dumps`` as the bare token NaN, which jq and
    JavaScript's JSON.parse refuse (the whole file unreadable); control-grid's summary goes
    through terrain.io.jsonfile.strict_json and writes null. control-sim now does too."""
    metrics = {"peak_slip": math.nan, "slip_rmse": math.inf, "energy_j_per_m": 12.5,
               "distance_m": 1.25, "speed_limit_clipped_steps": [0, 0],
               "correction_clipped_steps": [0, 0]}

    def fake_run(*args, **kwargs):
        return None, None, dict(metrics)

    monkeypatch.setattr(control_sim, "run_closed_loop", fake_run)
    out = tmp_path / "r.json"
    assert main(["control-sim", "--vehicle", "husky", "--terrain", "ICE", "--scenario",
                 "straight_accel", "--controller", "traction", "--duration-s", "1",
                 "--terrain-source", "label", "--json", str(out)]) == 0
    r = _strict_loads(out.read_text())
    assert r["peak_slip"] is None and r["slip_rmse"] is None
    # finite figures are kept in full, as before
    assert (r["energy_j_per_m"], r["distance_m"]) == (12.5, 1.25)
    assert (r["vehicle"], r["terrain"], r["controller"]) == ("husky", "ICE", "traction")
    capsys.readouterr()
