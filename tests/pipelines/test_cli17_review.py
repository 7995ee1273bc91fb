"""Review cli17: bad command-line values that were taken silently."""

from __future__ import annotations

import pytest

from cli_helpers import exit_code


@pytest.mark.parametrize("address", ["", "  "])
@pytest.mark.parametrize("backend", ["dask", "ray"])
def test_an_empty_cluster_address_is_refused_not_a_local_cluster(address, backend, capsys):
    # `--address $SCHEDULER` with the variable unset: the grid ran on a local cluster of this
    # machine, unsaid, instead of the scheduler meant
    assert exit_code(["compare", "--backend", backend, "--address", address]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "argument --address" in err and "empty address" in err
