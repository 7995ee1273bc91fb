import pytest

from terrain.sim import SimConfig, simulate


@pytest.fixture(scope="session")
def husky_orchard():
    """Husky, orchard scenario on asphalt, all effects off."""
    return simulate(SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="orchard",
                              duration_s=120.0, seed=7))
