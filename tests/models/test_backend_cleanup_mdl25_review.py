"""Review (mdl25): what a failing cell leaves of a joblib back-end (Dask client, backend).

The comparison routes its cells through ``joblib.parallel_config`` inside
:func:`terrain.models.compare.joblib_backend`; a cell that raises must leave joblib on the
caller's backend and no Dask client connected to the cluster.
"""

from __future__ import annotations

import pytest

from terrain.models.compare import joblib_backend

distributed = pytest.importorskip("distributed")


def _backend_name() -> str:
    from joblib.parallel import get_active_backend

    return type(get_active_backend()[0]).__name__


def test_a_failing_cell_on_a_dask_cluster_disconnects_and_restores_joblib():
    before = _backend_name()
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        with pytest.raises(KeyboardInterrupt):
            with joblib_backend("dask", cluster.scheduler_address):
                assert _backend_name() != before
                raise KeyboardInterrupt
        assert _backend_name() == before
        with pytest.raises(ValueError):      # no client left connected
            distributed.Client.current()
        assert not cluster.scheduler.clients.keys() - {"fire-and-forget"}


def test_a_failing_cell_on_the_local_backend_restores_the_callers_backend():
    from joblib import parallel_config

    with parallel_config(backend="threading"):      # the caller's own choice
        with pytest.raises(RuntimeError):
            with joblib_backend("loky"):
                assert _backend_name() == "LokyBackend"
                raise RuntimeError("cell failed")
        assert _backend_name() == "ThreadingBackend"
