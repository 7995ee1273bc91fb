"""Review (cmp4) of the comparison grid, the CV metrics and their backends."""

import sys

import pytest

from terrain.errors import ConfigError
from terrain.models.compare import check_backend, joblib_backend


def test_the_dask_backend_without_distributed_is_a_config_error(monkeypatch):
    """``joblib_backend`` says a backend whose library is missing is a ConfigError; for
    ``dask`` it was Python's bare ModuleNotFoundError, raised after ``check_backend`` had
    passed it (so ``terrain compare`` had opened its MLflow run)."""
    monkeypatch.setitem(sys.modules, "distributed", None)   # import of it fails
    with pytest.raises(ConfigError, match="dask backend needs"):
        check_backend("dask", None)
    with pytest.raises(ConfigError, match="dask backend needs"):
        with joblib_backend("dask", "tcp://scheduler:8786"):
            pass
