"""Validation harnesses and report tables (outside the library :mod:`terrain`).

* :mod:`pipelines.validation.harness`: estimators against simulated truth (shared by the
  tests, ``benchmarks/bench_ekf.py`` and the report);
* :mod:`pipelines.validation.estimation_tables`: every table of
  ``docs/estimation_validation.md``;
* :mod:`pipelines.validation.sim_tables`: the tables of ``docs/sim_validation.md``;
* :mod:`pipelines.validation.figures`: the figure of each report.

``terrain validate {estimation,sim}`` (:mod:`pipelines.validate`) prints the tables and,
with ``--out``, draws the figures beside the file.
"""
