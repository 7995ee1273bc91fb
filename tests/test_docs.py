"""The README and docs/ agree with the command line they describe.

* the stated range of ``terrain estimate --rate-hz`` is the one the code checks.
"""

from __future__ import annotations

import re
from pathlib import Path

from terrain.estimation.runner import MAX_RATE_HZ, MIN_RATE_HZ

ROOT = Path(__file__).resolve().parents[1]


def test_readme_states_the_rate_range_the_code_checks():
    # README said (0, 10000] Hz; check_rate_hz refuses below MIN_RATE_HZ = 1 Hz
    text = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    (low, high), = re.findall(r"`--rate-hz` a rate in \[([\d.]+), ([\d.]+)\] Hz", text)
    assert (float(low), float(high)) == (MIN_RATE_HZ, MAX_RATE_HZ)
