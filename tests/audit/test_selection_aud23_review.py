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


@pytest.mark.parametrize("n_runs, min_units, n_units, segmented", [
    (4, 4, 4, False),     # exactly min_units runs: one unit each, not cut
    (5, 4, 5, False),
    (3, 4, 6, True),      # one run short: each cut into ceil(4 / 3) = 2 segments
    (1, 4, 4, True),      # a single run: min_units segments
    (2, 2, 2, False),     # the smallest min_units, met exactly
    (1, 2, 2, True),
])
def test_runs_are_cut_into_segments_only_below_min_units(n_runs, min_units, n_units,
                                                         segmented):
    """make_units keeps one unit per run from exactly ``min_units`` runs up, and below it
    cuts every run into ``ceil(min_units / n_runs)`` segments (at least min_units units)."""
    from audit_helpers import synthetic_frame

    from terrain.audit.selection import make_units

    frames = [synthetic_frame(f"r{k}", seed=k, n_cycles=1) for k in range(n_runs)]
    units, cut = make_units(frames, min_units, lambda f: True)
    assert (len(units), cut) == (n_units, segmented)
    assert len({f.group for u in units for f in u}) == n_units
