"""Boundary of the CLI's one-line error: a message of exactly 500 characters is printed
whole, one character more is cut to 500 ending ``...`` (cli22 review)."""

from __future__ import annotations

import pytest

from terrain.cli import _one_line
from terrain.errors import ConfigError


@pytest.mark.parametrize("length", [499, 500, 501, 502])
def test_a_message_at_the_limit_is_whole_and_past_it_cut_to_the_limit(length):
    text = "".join(chr(ord("a") + i % 26) for i in range(length))
    line = _one_line(ConfigError(text))
    if length <= 500:
        assert line == text
    else:
        assert len(line) == 500 and line == text[:497] + "..."
