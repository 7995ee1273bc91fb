"""Review srv20 of the served model's limits at their edges, end to end through the request
guard and MLflow's ``/invocations`` handler: ``--max-decisions`` (a request whose decisions
are due exactly at its last sample)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from terrain.run import WHEEL_CHANNELS
from terrain.serving.http import RequestGuard
from terrain.serving.pyfunc import save_model
from terrain.serving.request import parse_request, planned_decisions
from terrain.serving.served import save_served_model, served_settings
from test_served_fuzz_srv15_review import answer, encode  # same folder

WHEELS = {"wheels": WHEEL_CHANNELS}
LIMIT = 4


@pytest.fixture(scope="module")
def limited(wheel_model, tmp_path_factory):
    """The wheel model served with ``max_decisions`` of :data:`LIMIT`, behind the guard."""
    import mlflow.pyfunc
    from mlflow.pyfunc import scoring_server

    root, m = tmp_path_factory.mktemp("srv20_limits"), wheel_model
    save_model(root / "train", m.pipeline, m.channels, m.window, m.classes, {"dataset": "t"})
    save_served_model(root / "served", root / "train", served_settings(m, max_decisions=LIMIT))
    return RequestGuard(scoring_server.init(mlflow.pyfunc.load_model(str(root / "served"))),
                        max_body_bytes=10**7)


def _wheels(t: np.ndarray, base: pd.DataFrame) -> pd.DataFrame:
    """The wheel samples of ``base`` (cycled) at the stamps ``t``."""
    rows = base.iloc[np.arange(t.size) % len(base)].reset_index(drop=True)
    return rows.assign(t_s=t)


def _due(t0: float, last: float, window_s: float = 2.0, hop_s: float = 0.5) -> int:
    """Decisions the service makes: one at ``t0 + window_s + k * hop_s`` (computed as its
    clock does) while that time is not after the newest sample."""
    origin, k = t0 + window_s, 0
    while origin + k * hop_s <= last:
        k += 1
    return k


@pytest.mark.parametrize("t0", [0.1, 7.7])
def test_a_request_making_one_decision_more_than_max_decisions_is_refused(
        limited, unseen_wheel_request, t0):
    """0.1 + 25 x 0.16 is 4.1, but 4.1 - 0.1 is 3.9999999999999996: the span's floor planned
    4 decisions where the service makes 5 (the fifth due at 2.1 + 4 x 0.5 = 4.1, the last
    sample), so a request beyond ``--max-decisions 4`` was answered with 5 decisions."""
    frame = _wheels(t0 + np.arange(26) * 0.16, unseen_wheel_request(4.0))
    assert _due(t0, frame["t_s"].iloc[-1]) == LIMIT + 1
    status, doc = answer(limited, *encode(frame, "csv"))
    assert status == 400, (status, len(doc.get("predictions", [])))
    assert doc["message"].startswith("DataFormatError: request spanning 4 s would make 5 "
                                     "decisions (one every 0.5 s), above the limit of 4")


def test_a_request_making_exactly_max_decisions_is_answered_with_all(limited,
                                                                     unseen_wheel_request):
    frame = _wheels(0.1 + np.arange(23) * 0.16, unseen_wheel_request(4.0))   # to 3.62 s
    assert _due(0.1, frame["t_s"].iloc[-1]) == LIMIT
    status, doc = answer(limited, *encode(frame, "csv"))
    assert status == 200 and len(doc["predictions"]) == LIMIT


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck))
@given(t0=st.floats(0.0, 5000.0), step=st.sampled_from([0.125, 0.15, 0.16, 0.2]),
       n=st.integers(14, 60))
@example(t0=0.1, step=0.16, n=26)
@example(t0=7.7, step=0.16, n=26)
def test_planned_decisions_bound_the_decisions_due(unseen_wheel_request, t0, step, n):
    """The plan counts the decision times as the service's clock computes them: never fewer
    than are due (a request past the limit would pass) nor more."""
    t = t0 + np.arange(n) * step
    if t[-1] - t[0] < 2.0:
        return
    run = parse_request(_wheels(t, unseen_wheel_request(4.0)), WHEELS, 2.0, 10_000)
    first = float(run.streams["wheels"]["t_s"].iloc[0])
    assert planned_decisions(run, 2.0, 0.5) == _due(first, float(t[-1]))
