"""Review aud28: the terminal summary says when a gain is scored between segments of runs.

``terrain audit`` on a folder with one run cuts it into segments (too few runs for
leave-one-run-out) and printed ``ICE: icr_expansion (chi=1.48; gain 0.38)``, the line a
leave-one-run-out gain gets: only the Markdown report said the figure says nothing about
other runs.
"""

from __future__ import annotations

from terrain.audit.report import summary_lines


def _effect(name, terrain, group, gain, n_runs):
    return {"name": name, "terrain": terrain, "group": group, "supported": True,
            "params": {"p": 1.0}, "heldout_gain": gain, "n_runs": n_runs}


def test_a_gain_between_segments_says_so_with_its_run_count():
    report = {"runs": {"audited": ["a", "b", "c", "d", "e"], "skipped": {}},
              "terrains": ["ICE", "SNOW"],
              "supported": {"ICE": ["icr_expansion", "current_offset"],
                            "SNOW": ["current_offset"]},
              "groups": [{"terrain": "ICE", "group": "yaw", "segmented": True},
                         {"terrain": "ICE", "group": "current", "segmented": False},
                         {"terrain": "SNOW", "group": "current", "segmented": True}],
              "effects": [_effect("icr_expansion", "ICE", "yaw", 0.38, 1),
                          _effect("current_offset", "ICE", "current", 0.17, 4),
                          _effect("current_offset", "SNOW", "current", 0.2, 2)]}
    lines = summary_lines(report, {"s": 1.0})
    assert lines[1:] == [
        "  ICE: icr_expansion (p=1; gain 0.38 on held-out segments of 1 run), "
        "current_offset (p=1; gain 0.17)",
        "  SNOW: current_offset (p=1; gain 0.20 on held-out segments of 2 runs)"]
