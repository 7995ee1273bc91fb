"""State of the commands (aud24): a command's ``main`` leaves the caller's parsed arguments
as they were, so that the same ``argparse.Namespace`` run twice runs the same command."""

from __future__ import annotations

import argparse
import copy

import pytest

from pipelines import stream_eval


class _Stop(Exception):
    """Raised where a command would start its long work (the runs read)."""


def _stop(*args, **kwargs):
    raise _Stop()


def _parsed(module, argv):
    parser = argparse.ArgumentParser()
    module.add_arguments(parser)
    return parser.parse_args(argv)


@pytest.mark.parametrize("argv", [["--part", "wheel-cv"], ["--part", "streams"], []])
def test_stream_eval_main_leaves_the_parsed_arguments_as_they_were(monkeypatch, argv):
    # main filled the defaults into the caller's Namespace (--folds 5, --window-s...): the
    # same arguments run again were refused ("--folds shapes the held-out streams; --part
    # wheel-cv does not run them"), as if the user had given the defaults
    monkeypatch.setattr(stream_eval, "load_dataset", _stop)
    args = _parsed(stream_eval, argv)
    before = copy.deepcopy(vars(args))
    for _ in range(2):
        with pytest.raises(_Stop):
            stream_eval.main(args)
        assert vars(args) == before


def _open_figures():
    import matplotlib.pyplot as plt

    return set(plt.get_fignums())


def _slip_frame():
    import numpy as np
    import pandas as pd

    from pipelines.validation.figures import TUNINGS

    t = np.arange(0.0, 3.0, 0.1)
    return pd.concat([pd.DataFrame({"terrain": terrain, "tuning": tuning, "t_s": t,
                                    "slip_true": 0.1, "slip_est": 0.1, "nis": 1.0,
                                    "dof": 2.0, "seed": 1})
                      for terrain in ("TILES", "GRASS") for tuning in TUNINGS],
                     ignore_index=True)


@pytest.mark.slow
def test_a_validation_figure_that_cannot_be_written_is_closed_all_the_same(tmp_path):
    # the figure was drawn on pyplot and closed only after its file was written: a write
    # that failed (a missing folder, a full disk) left it open in pyplot's registry, a
    # figure more held in memory by a process that draws again
    from pipelines.validation.figures import plot_slip_tracking

    before = _open_figures()
    with pytest.raises(OSError):
        plot_slip_tracking(_slip_frame(), tmp_path / "missing" / "slip.png")
    assert _open_figures() == before
    path = plot_slip_tracking(_slip_frame(), tmp_path / "slip.png")
    assert path.is_file() and _open_figures() == before


def test_a_straight_line_figure_that_cannot_be_written_is_closed_all_the_same(tmp_path,
                                                                              monkeypatch):
    import numpy as np

    from pipelines.validation import figures

    t = np.arange(0.0, 2.0, 0.1)
    monkeypatch.setattr(figures, "straight_line_slip",
                        lambda terrain, duration_s, seed: (t, 0.1 + 0 * t))
    before = _open_figures()
    with pytest.raises(OSError):
        figures.plot_straight_line(tmp_path / "missing" / "line.png")
    assert _open_figures() == before


def test_control_grid_plots_that_cannot_be_written_are_closed_all_the_same(tmp_path):
    import numpy as np
    import pandas as pd

    from pipelines.control_grid import _plots

    t = np.arange(0.0, 2.0, 0.1)
    trace = pd.DataFrame({"t_s": t, "slip_true_1": 0.1, "target_1": 0.1})
    traces = {("husky", "ICE", "straight_accel", ctrl, 0): trace
              for ctrl in ("off", "traction")}
    table = pd.DataFrame({"vehicle": ["husky"], "terrain": ["ICE"],
                          "scenario": ["straight_accel"], "energy_off": [1.0],
                          "energy_on": [0.9]})
    before = _open_figures()
    with pytest.raises(OSError):
        _plots(traces, table, tmp_path / "missing")
    assert _open_figures() == before
    assert len(_plots(traces, table, tmp_path)) == 2 and _open_figures() == before


def test_control_grid_main_leaves_the_parsed_terrains_as_they_were(monkeypatch, tmp_path):
    # main upper-cased --terrains in the caller's Namespace (ice -> ICE)
    from pipelines import control_grid

    monkeypatch.setattr(control_grid, "check_grid", _stop)
    args = _parsed(control_grid, ["--terrains", "ice", "Grass", "--out", str(tmp_path / "g")])
    before = copy.deepcopy(vars(args))
    with pytest.raises(_Stop):
        control_grid.main(args)
    assert vars(args) == before
