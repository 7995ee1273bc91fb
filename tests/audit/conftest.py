"""Fixtures of the audit tests (helpers in :mod:`audit_helpers`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from audit_helpers import audit_folder, simulated_streams, write_signal_files
from terrain.io.shipped import read_shipped


@pytest.fixture(scope="session")
def audit_tmp(tmp_path_factory):
    """Factory of fresh folders for planted data sets."""
    def make(name: str) -> Path:
        return tmp_path_factory.mktemp(name)
    return make


@pytest.fixture(scope="session")
def sim_null(audit_tmp):
    """Audit of simulated ASPHALT runs with nothing planted, and their streams."""
    streams = simulated_streams()
    root = audit_tmp("sim_null")
    for i, (imu, pro) in enumerate(streams):
        write_signal_files(root, "ASPHALT", i, imu, pro)
    return audit_folder(root), streams


@pytest.fixture(scope="session")
def shipped_borealtc():
    """Every shipped BorealTC run (read once)."""
    return {r.run_id: r for r in read_shipped("borealtc")}
