"""Digests of what a simulated run depends on, for the caches of simulated runs and models.

A cache of simulated runs (``terrain slip-fit``'s ``out/slip_cache``) or of models trained on
them (``control-grid``'s ``out/control_classifier``) is valid only while the simulator gives
the same runs. Parameters alone do not say that: a change of the integrator (for instance
the implicit step at the friction limit) changes every run with the same parameters. So the
digest covers both the parameters (the catalogue entries of the vehicle and the terrains,
the vehicle's default sensor settings) and the source code of the modules that compute the
runs (:data:`SIMULATOR_MODULES`). Any edit of that code, a comment included, invalidates the
caches: a rerun costs minutes, a stale run silently reused costs a wrong figure.
"""

from __future__ import annotations

import hashlib
import importlib.util
from pathlib import Path
from typing import Sequence

from terrain.errors import ConfigError
from terrain.sim.simulate import DEFAULT_SENSORS, SimConfig, is_name_sequence
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

#: Modules whose code computes a simulated run: the simulator, the wheel-terrain physics,
#: the vehicle models, the run container and the error types (the import closure of
#: :func:`terrain.sim.simulate.simulate` inside the project).
SIMULATOR_MODULES: tuple[str, ...] = ("terrain.sim", "terrain.terramechanics",
                                      "terrain.vehicles", "terrain.run", "terrain.errors")


def _source_files(module: str) -> tuple[Path, list[Path]]:
    """The folder of a module or package and its source files (sorted)."""
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        raise ConfigError(f"source digest: no module {module!r}")
    origin = Path(spec.origin)
    if spec.submodule_search_locations:  # a package: every .py file below it
        return origin.parent, sorted(origin.parent.rglob("*.py"))
    return origin.parent, [origin]


def source_digest(modules: Sequence[str]) -> str:
    """SHA-1 digest of the source code of modules and packages.

    Parameters
    ----------
    modules : sequence of str
        Dotted module or package names; a package contributes every ``.py`` file below its
        folder (sorted by path relative to the package), a module its file.

    Returns
    -------
    str
        SHA-1 hex digest (40 characters) over each file's name relative to its package or
        module and its bytes, in the order given.

    Raises
    ------
    ConfigError
        A module that cannot be found, or ``modules`` not a sequence of names (one string,
        bytes, a number).
    """
    if not is_name_sequence(modules):
        # "terrain.sim" was read letter by letter ("source digest: no module 't'")
        raise ConfigError(f"source_digest: modules must be a sequence of module names, got "
                          f"{type(modules).__name__} {modules!r:.60}")
    h = hashlib.sha1()
    for module in modules:
        # relative to the package's folder (the first file's folder was a subpackage's
        # when one sorted before __init__.py, and the other files raised ValueError)
        root, files = _source_files(module)
        for path in files:
            h.update(f"{module}:{path.relative_to(root).as_posix()}\n".encode())
            h.update(path.read_bytes())
    return h.hexdigest()


def simulator_digest(vehicle: str, terrains: Sequence[str]) -> str:
    """Digest of what shapes a vehicle's simulated runs on some terrains.

    The default physics version of :class:`terrain.sim.simulate.SimConfig`, the vehicle's
    default sensor settings (:data:`terrain.sim.simulate.DEFAULT_SENSORS`: rates, noise,
    vibration bandwidth), the catalogue parameters of the vehicle and of the terrains
    (traction curves, vibration levels), as their dataclass ``repr``, and the source of
    :data:`SIMULATOR_MODULES` (:func:`source_digest`).

    Parameters
    ----------
    vehicle : str
        Simulated vehicle.
    terrains : sequence of str
        Catalogued terrain classes (any case; order does not matter).

    Returns
    -------
    str
        SHA-1 hex digest, 10 characters.

    Raises
    ------
    ConfigError
        Unknown vehicle or terrain, or ``terrains`` not a sequence of names (one string,
        a number).
    """
    if not is_name_sequence(terrains):
        # "ASPHALT" was read letter by letter ("unknown terrain 'A'"), 5 a bare TypeError
        raise ConfigError(f"simulator_digest: terrains must be a sequence of terrain names, "
                          f"got {type(terrains).__name__} {terrains!r:.60}")
    params = get_vehicle(vehicle)
    parts = [SimConfig().physics, repr(DEFAULT_SENSORS[params.name]), repr(params)]
    parts += [repr(get_terrain(t)) for t in sorted(str(t).upper() for t in terrains)]
    parts.append(source_digest(SIMULATOR_MODULES))
    return hashlib.sha1("\n".join(parts).encode()).hexdigest()[:10]
