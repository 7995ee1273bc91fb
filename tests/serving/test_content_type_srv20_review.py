"""Review srv20: a Content-Type MLflow refuses (a charset other than UTF-8, a parameter it
does not know) is answered the same 415 whatever the body; the guard's body checks answered
some bodies under it 400 first (a ragged row, a repeated JSON key...), so one header got two
verdicts."""

from __future__ import annotations

import pytest

from terrain.serving.http import RequestGuard
from terrain.serving.pyfunc import save_model
from terrain.serving.served import save_served_model, served_settings
from test_served_fuzz_srv15_review import answer, encode  # same folder


@pytest.fixture(scope="module")
def guarded(wheel_model, tmp_path_factory):
    """The wheel model served behind the request guard, as ``terrain serve`` builds it."""
    import mlflow.pyfunc
    from mlflow.pyfunc import scoring_server

    root, m = tmp_path_factory.mktemp("srv20_types"), wheel_model
    save_model(root / "train", m.pipeline, m.channels, m.window, m.classes, {"dataset": "t"})
    save_served_model(root / "served", root / "train", served_settings(m))
    return RequestGuard(scoring_server.init(mlflow.pyfunc.load_model(str(root / "served"))),
                        max_body_bytes=10**7)


@pytest.fixture(scope="module")
def base(unseen_wheel_request):
    """4 s of the wheel stream of an unseen run, long format."""
    return unseen_wheel_request(4.0)


CSV_TYPES = ["text/csv; charset=latin-1", "text/csv; charset=utf8", "text/csv; header=present",
             "text/csv; =x", "TEXT/CSV; Charset=ISO-8859-1"]
JSON_TYPES = ["application/json; format=pandas-split", "application/json; charset=utf-16"]


def _bodies(frame):
    """Bodies of ``frame`` in each format: two as sent (CSV: the second with a byte-order
    mark and CR LF), then ones the guard's checks refuse."""
    csv, _ = encode(frame, "csv")
    split, _ = encode(frame, "split")
    lines = csv.split(b"\n")
    twice = lines[0] + b",vel_l\n" + b"\n".join(line + b",1" for line in lines[1:-1])
    return {
        "csv": [csv, b"\xef\xbb\xbf" + csv.replace(b"\n", b"\r\n"),
                b"\n".join([lines[0], lines[1] + b",9", *lines[2:]]),   # ragged
                csv.replace(b"\nwheels,", b"\nwheels,1e400", 1),       # a huge number
                twice + b"\n"],                                         # a column twice
        "json": [split, b" " + split,
                 split.replace(b'"columns"', b'"columns": [], "columns"', 1),   # key twice
                 split[:-1] + b', "params": {}}'],
    }


@pytest.mark.parametrize("content_type", CSV_TYPES + JSON_TYPES)
def test_a_content_type_mlflow_refuses_gets_one_answer_whatever_the_body(
        guarded, base, content_type):
    kind = "json" if "json" in content_type.lower() else "csv"
    answers = [answer(guarded, body, content_type) for body in _bodies(base)[kind]]
    status, doc = answers[0]
    assert status == 415 and doc["message"].startswith(
        "DataFormatError: unsupported request content type"), doc
    assert all(a == answers[0] for a in answers), answers


@pytest.mark.parametrize("content_type", ["text/csv", "text/csv; charset=utf-8",
                                          'TEXT/CSV;Charset="UTF-8"', "text/csv;"])
def test_the_body_checks_still_run_under_a_content_type_mlflow_takes(
        guarded, base, content_type):
    ragged = _bodies(base)["csv"][2]
    status, doc = answer(guarded, ragged, content_type)
    assert status == 400 and doc["message"].startswith("RaggedRowError: a row of 7 fields"), doc


@pytest.mark.parametrize("kind", ["csv", "json"])
def test_the_bodies_are_refused_under_the_plain_type(guarded, base, kind):
    """The bodies after the first two are refused by the guard's checks under the plain type,
    so the test above compares answers the checks would have changed."""
    plain = "text/csv" if kind == "csv" else "application/json"
    bodies = _bodies(base)[kind]
    assert answer(guarded, bodies[0], plain)[0] == answer(guarded, bodies[1], plain)[0] == 200
    for body in bodies[2:]:
        status, doc = answer(guarded, body, plain)
        assert status == 400 and not doc["message"].startswith(
            "DataFormatError: unsupported"), doc
