"""Write a :class:`~terrain.sim.simulate.SimResult` in the measured-data layout.

``DIR/<TERRAIN>/<stream>_XX.csv`` and ``DIR/<TERRAIN>/meta_XX.json``, ``XX`` the next free
two-digit index in that folder. ``<TERRAIN>`` is the run's terrain, ``MIXED`` when the path
crosses several (per-sample labels are in ``truth_XX.csv``).
"""

from __future__ import annotations

import json
from pathlib import Path

from terrain.errors import ConfigError


def next_index(folder: Path) -> int:
    """Smallest index ``XX`` not used by any ``*_XX.*`` file of ``folder``."""
    used = set()
    if folder.is_dir():
        for p in folder.iterdir():
            stem = p.stem
            if "_" in stem and stem.rsplit("_", 1)[1].isdigit():
                used.add(int(stem.rsplit("_", 1)[1]))
    i = 0
    while i in used:
        i += 1
    return i


def write_run(result, out_dir: str | Path, index: int | None = None) -> dict[str, Path]:
    """Write every stream of a simulated run and its metadata.

    Parameters
    ----------
    result : SimResult
    out_dir : str or Path
        Root folder; the run goes to ``out_dir / <TERRAIN>``.
    index : int, optional
        Run index (default: next free one).

    Returns
    -------
    dict
        Stream name (and ``meta``) -> written path.

    Raises
    ------
    ConfigError
        Index out of range [0, 99] or already used.
    """
    folder = Path(out_dir) / str(result.meta["terrain"])
    folder.mkdir(parents=True, exist_ok=True)
    idx = next_index(folder) if index is None else int(index)
    if not 0 <= idx <= 99:
        raise ConfigError(f"run index must be in [0, 99], got {idx}")
    if (folder / f"meta_{idx:02d}.json").exists():
        raise ConfigError(f"run index {idx:02d} already used in {folder}")
    paths: dict[str, Path] = {}
    for name, frame in result.streams.items():
        path = folder / f"{name}_{idx:02d}.csv"
        frame.to_csv(path, index=False, float_format="%.9g")
        paths[name] = path
    meta = dict(result.meta)
    meta["index"] = f"{idx:02d}"
    meta["files"] = {k: p.name for k, p in paths.items()}
    path = folder / f"meta_{idx:02d}.json"
    path.write_text(json.dumps(meta, indent=2, default=str))
    paths["meta"] = path
    return paths
