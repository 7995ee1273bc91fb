"""Review srv7a of :func:`terrain.serving.http.project_message`: the message bound
:data:`~terrain.serving.http.MAX_MESSAGE` at its edge (mutant ``<=`` -> ``<`` cut a message
of exactly the bound, and no test failed)."""

from __future__ import annotations

from terrain.serving.http import MAX_MESSAGE, project_message


def test_a_message_of_exactly_the_bound_is_kept_whole_and_one_longer_cut_to_it():
    head = "DataFormatError: "
    exact = head + "x" * (MAX_MESSAGE - len(head))
    assert project_message(400, exact) == exact
    longer = exact + "y"
    cut = project_message(400, longer)
    assert len(cut) == MAX_MESSAGE and cut == exact[:MAX_MESSAGE - 3] + "..."
    # a 5xx message is bound the same way
    assert project_message(500, "internal error " + "z" * MAX_MESSAGE).endswith("...")
