"""Boundaries of :class:`terrain.tracking.TrackedRun`'s length limits: a parameter or
the non-finite metrics tag exactly at MLflow's limit is kept whole, one character more is
cut with its note, never past the limit (cli22 review; a stand-in client, no store)."""

from __future__ import annotations

from types import SimpleNamespace

from hypothesis import given, settings, strategies as st

from terrain.tracking import NON_FINITE_FILE, PARAM_LIMIT, TAG_LIMIT, TrackedRun


class _Client:
    """Records what a TrackedRun hands MLflow's client."""

    def __init__(self):
        self.params, self.tags, self.texts = {}, {}, {}

    def log_batch(self, run_id, metrics=(), params=()):
        self.params.update({p.key: p.value for p in params})

    def log_text(self, run_id, text, name):
        self.texts[name] = text

    def set_tag(self, run_id, key, value):
        self.tags[key] = value

    def get_run(self, run_id):
        return SimpleNamespace(data=SimpleNamespace(tags=dict(self.tags)))


def _run():
    client = _Client()
    return TrackedRun("r", "e", "sqlite:///x.db", client), client


@settings(max_examples=30, deadline=None)
@given(st.integers(-3, 3))
def test_a_parameter_at_the_limit_is_kept_whole_and_one_more_is_cut_to_it(offset):
    run, client = _run()
    value = "x" * (PARAM_LIMIT + offset)
    run.log_params({"p": value})
    logged = client.params["p"]
    if offset <= 0:
        assert logged == value and "params/p.txt" not in client.texts
    else:
        assert len(logged) == PARAM_LIMIT
        assert logged.endswith(f"... ({len(value)} characters in params/p.txt)")
        assert client.texts["params/p.txt"] == value


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(-3, 3))
def test_the_non_finite_tag_at_the_limit_lists_every_name_and_past_it_whole_names(
        width, offset):
    """Names whose comma-joined list is exactly TAG_LIMIT characters are listed whole (no
    file); one character more lists the first whole names and the count of the rest."""
    target = TAG_LIMIT + offset
    names, length = [], -1          # whole names of one width while the list fits
    while length + 1 + width + 5 <= target:
        names.append(f"{'m' * width}{len(names):05d}")
        length += 1 + width + 5
    names[-1] += "z" * (target - length)    # the last one padded to the exact length
    assert len(",".join(names)) == target and names == sorted(names)
    run, client = _run()
    run.log_metrics({k: float("nan") for k in names})
    tag = client.tags["non_finite_metrics"]
    assert len(tag) <= TAG_LIMIT
    if offset <= 0:
        assert tag == ",".join(names) and NON_FINITE_FILE not in client.texts
    else:
        listed, _, rest = tag.partition(",...")
        kept = listed.split(",") if listed else []
        assert kept == names[:len(kept)]
        assert rest == f" {len(names) - len(kept)} more in {NON_FINITE_FILE}"
        assert client.texts[NON_FINITE_FILE].splitlines() == names
