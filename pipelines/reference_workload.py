"""The fixed NumPy reference workload of the benchmarks: one sort of 4096 floats.

A benchmark times it in the same run as its own figures (``benchmarks/bench_sim.py``, next to
the simulations; ``benchmarks/bench_serving.py``, after every timed decision), so that a
figure over the reference is comparable between a loaded and a quiet machine where the
absolute times are not. Single-threaded, like the simulator and the streaming service.
"""

from __future__ import annotations

import time

import numpy as np

from terrain.errors import config_integer

#: The workload's input: 4096 standard normal floats of seed 0 (read-only).
REFERENCE_INPUT = np.random.default_rng(0).standard_normal(4096)
REFERENCE_INPUT.setflags(write=False)


def sort_reference_s() -> float:
    """Wall time of one run of the reference workload (sorting :data:`REFERENCE_INPUT`).

    Returns
    -------
    float
        Seconds.
    """
    start = time.perf_counter()
    np.sort(REFERENCE_INPUT)
    return time.perf_counter() - start


def sort_reference_ms(repeats: int = 200) -> float:
    """Median wall time of ``repeats`` runs of the reference workload.

    Parameters
    ----------
    repeats : int
        Runs timed (>= 1).

    Returns
    -------
    float
        Milliseconds.

    Raises
    ------
    ConfigError
        ``repeats`` not an integer >= 1 (0 was the median of no time: NaN ms).
    """
    config_integer("sort_reference_ms: repeats", repeats, 1)
    return 1e3 * float(np.median([sort_reference_s() for _ in range(repeats)]))
