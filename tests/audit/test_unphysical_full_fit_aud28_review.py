"""Review aud28: the physics rule judges the effect fitted on all units, not one fold.

Mutation review of the simulation audit: the mutant that judged ``unphysical`` on the fit
without the first unit (the first fold) instead of the fit on every unit passed the whole
audit suite. Here the first run turns twice as fast as its wheels command (``chi = 0.5``,
e.g. a gyro scale error) and the three others as ideal drive (``chi = 1``): pooled, chi
is below 1, which no ICR expansion gives; the first fold alone (runs 1-3) reads chi 1.
"""

from __future__ import annotations

from audit_helpers import synthetic_frame
from terrain.audit.selection import SelectionSettings, select_group


def test_a_chi_below_1_on_all_units_is_unphysical_even_when_one_fold_reads_1():
    units = [[synthetic_frame("s/ASPHALT/0", seed=0, chi=0.5)]]
    units += [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.0)] for i in (1, 2, 3)]
    g = select_group(units, "yaw", "ASPHALT",
                     SelectionSettings(n_bootstrap=50, n_param_bootstrap=0))
    icr = {e.name: e for e in g.effects}["icr_expansion"]
    assert icr.params["chi"] < 1.0
    assert "< 1" in icr.details.get("unphysical", "")
    assert not icr.supported
