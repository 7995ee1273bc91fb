"""Boundaries of the held-out scoring (terrain.audit.selection), review aud23: counts of
parameter-bootstrap resamples at the limit an interval needs."""

from __future__ import annotations

import pytest

from terrain.cli import main
from terrain.audit.selection import MIN_PARAM_BOOTSTRAP, SelectionSettings
from terrain.errors import ConfigError


@pytest.mark.parametrize("n", range(1, MIN_PARAM_BOOTSTRAP))
def test_fewer_parameter_resamples_than_an_interval_needs_are_refused(n):
    """A parameter interval needs MIN_PARAM_BOOTSTRAP (5) successful refits, so 1-4
    resamples refitted every effect 1-4 times and never gave an interval (silently); they
    are now refused, naming the setting and the two counts that work (0: none, >= 5)."""
    with pytest.raises(ConfigError, match=r"n_param_bootstrap .*0 .* at least 5"):
        SelectionSettings(n_param_bootstrap=n)


@pytest.mark.parametrize("n", [0, MIN_PARAM_BOOTSTRAP, MIN_PARAM_BOOTSTRAP + 1])
def test_no_parameter_resample_or_enough_for_an_interval_are_taken(n):
    """0 (no parameter intervals) and MIN_PARAM_BOOTSTRAP itself are both taken."""
    assert SelectionSettings(n_param_bootstrap=n).n_param_bootstrap == n


def test_the_option_refuses_too_few_parameter_resamples(capsys, tmp_path):
    """terrain audit --param-bootstrap 4 is a usage error (exit 2) naming the option."""
    with pytest.raises(SystemExit) as exc:
        main(["audit", "--dataset", "vulpi", "--json", str(tmp_path / "a.json"),
              "--param-bootstrap", "4"])
    assert exc.value.code == 2
    assert "argument --param-bootstrap" in capsys.readouterr().err
