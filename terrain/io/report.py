"""What the readers and the windowing step repaired, dropped or skipped, and why.

Every command builds one :class:`InputReport` from the runs it read (their ``meta``: repaired
cells, gaps, skipped blank/comment lines, seconds of one stream outside the other's span,
stuck sensors, plausibility warnings) and the
book-keeping of :func:`features.windows.make_windows` (windows kept and dropped per run,
runs skipped for a missing stream, runs shorter than one window). The command prints
:meth:`InputReport.text` (a few lines), logs :meth:`InputReport.metrics` to MLflow and the
per-run :attr:`InputReport.table` as ``input_report.csv``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import pandas as pd

from terrain.run import Run


def seconds_text(seconds: float) -> str:
    """A duration for a message: one decimal, or three significant digits beyond 1e6 s.

    A corrupt timestamp (``-1e300``) made a 300-digit gap in the input report.

    Parameters
    ----------
    seconds : float
        Duration, s.

    Returns
    -------
    str
        ``"12.3 s"`` or ``"1e+300 s"``.
    """
    return f"{seconds:.1f} s" if abs(seconds) < 1e6 else f"{seconds:.3g} s"


#: columns of :attr:`InputReport.table`
COLUMNS = ("run_id", "status", "reason", "repaired_cells", "repaired", "gaps", "gap_s",
           "gap_list", "skipped_lines", "ignored_columns", "unused_imu_s", "unused_wheels_s",
           "stuck", "windows", "dropped_gap", "empty_gap", "dropped_unsteady",
           "partition_tail_s", "window_tail_s", "between_windows_s", "flagged_windows",
           "warnings")
#: streams whose seconds outside the other's span the report counts (rule clock_overlap)
UNUSED_STREAMS = ("imu", "wheels")


@dataclass(frozen=True)
class InputReport:
    """Per-run account of the input of one command.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per run, columns :data:`COLUMNS`: ``status`` is ``used``, ``skipped`` or
        ``too_short`` with the ``reason``; ``repaired`` lists ``<stream>.<channel>:<cells>``;
        ``gaps`` / ``gap_s`` count the timestamp gaps and the time they span (s);
        ``ignored_columns`` lists ``<stream>.<column>`` of file columns no reader reads;
        ``unused_imu_s`` / ``unused_wheels_s`` are the seconds of that stream before or
        after the other stream's span (``Run.meta["unused_s"]``, rule ``clock_overlap``),
        left out wherever both streams are aligned, warned about only beyond 2 s and a
        tenth of the overlap;
        ``stuck`` lists stuck channels; ``partition_tail_s`` is the time after a run's last
        full partition, which no window is cut from (s; 0 without partitions), and
        ``window_tail_s`` the time after the last window of the run or of each partition,
        which no window covers (s), and ``between_windows_s`` the time between windows cut
        at a hop longer than the window, which no window covers either (s); ``windows`` is
        -1 for a run the command does not window (the other window columns,
        ``dropped_gap`` to ``between_windows_s``, are 0 then,
        and :meth:`metrics` leaves them out).
    """

    table: pd.DataFrame

    def metrics(self, prefix: str = "input_") -> dict[str, float]:
        """Totals for MLflow: runs used/skipped/too short, repaired cells, gaps, ignored
        file columns, seconds of each stream outside the other's span, windows dropped and
        flagged, partition and window tails and time between windows not windowed (s),
        stuck channels, warnings.

        Parameters
        ----------
        prefix : str
            Prefix of every metric name.

        Returns
        -------
        dict
            Metric name -> value.
        """
        t = self.table
        windowed = t["windows"] >= 0
        return {f"{prefix}{k}": float(v) for k, v in {
            "runs": len(t), "runs_used": int((t["status"] == "used").sum()),
            "runs_skipped": int((t["status"] == "skipped").sum()),
            "runs_too_short": int((t["status"] == "too_short").sum()),
            "repaired_cells": int(t["repaired_cells"].sum()), "gaps": int(t["gaps"].sum()),
            "gap_s": float(t["gap_s"].sum()),
            "skipped_lines": int(t["skipped_lines"].sum()),
            "ignored_columns": int(t["ignored_columns"].str.count(",").add(
                t["ignored_columns"] != "").sum()),
            **{f"unused_{k}_s": float(t[f"unused_{k}_s"].sum()) for k in UNUSED_STREAMS},
            "stuck_channels": int(t["stuck"].str.count(",").add(t["stuck"] != "").sum()),
            "windows_dropped_gap": int(t.loc[windowed, "dropped_gap"].sum()),
            "windows_empty_gap": int(t.loc[windowed, "empty_gap"].sum()),
            "windows_dropped_unsteady": int(t.loc[windowed, "dropped_unsteady"].sum()),
            "partition_tail_s": float(t.loc[windowed, "partition_tail_s"].sum()),
            "window_tail_s": float(t.loc[windowed, "window_tail_s"].sum()),
            "between_windows_s": float(t.loc[windowed, "between_windows_s"].sum()),
            "windows_flagged": int(t.loc[t["flagged_windows"] > 0, "flagged_windows"].sum()),
            "warnings": int(t["warnings"].sum()),
        }.items()}

    def text(self, limit: int = 4) -> str:
        """A compact account (a few lines) of what was repaired, dropped or skipped, and why.

        Parameters
        ----------
        limit : int
            Run ids shown per item before ``and N more``.

        Returns
        -------
        str
            Lines without trailing newline.
        """
        t, m = self.table, self.metrics("")
        ids = (lambda mask: _short(list(t.loc[mask, "run_id"]), limit))
        parts = [f"input: {int(m['runs'])} run(s), {int(m['runs_used'])} used"]
        if m["repaired_cells"]:
            per = (t.loc[t["repaired_cells"] > 0, ["run_id", "repaired"]]
                   .apply(lambda r: f"{r.run_id} ({r.repaired})", axis=1))
            parts.append(f"  repaired {int(m['repaired_cells'])} isolated non-finite cell(s) "
                         f"by linear interpolation: {_short(list(per), limit)}")
        if m["skipped_lines"]:
            parts.append(f"  skipped {int(m['skipped_lines'])} blank/comment line(s): "
                         f"{ids(t['skipped_lines'] > 0)}")
        if m["ignored_columns"]:
            names = sorted({c for cols in t["ignored_columns"] if cols
                            for c in cols.split(",")})
            parts.append(f"  ignored {int(m['ignored_columns'])} column(s) not read by the "
                         f"readers ({_short(names, limit)}) in "
                         f"{ids(t['ignored_columns'] != '')}")
        unused = {k: m[f"unused_{k}_s"] for k in UNUSED_STREAMS if m[f"unused_{k}_s"] > 0}
        if unused:
            mask = t[[f"unused_{k}_s" for k in UNUSED_STREAMS]].sum(axis=1) > 0
            parts.append("  not used: " + ", ".join(f"{seconds_text(v)} of {k}" for k, v in
                                                    unused.items())
                         + " outside the other stream's span (only the overlap is aligned) "
                         f"in {ids(mask)}")
        if m["gaps"]:
            lengths = [float(b) - float(a) for spans in t["gap_list"] if spans
                       for a, b in (g.split("..") for g in spans.split(";"))]
            sizes = _short([seconds_text(x) for x in lengths], limit)
            total = f"; {seconds_text(m['gap_s'])} in all" if len(lengths) > 1 else ""
            parts.append(f"  {int(m['gaps'])} timestamp gap(s) ({sizes}{total}) in "
                         f"{ids(t['gaps'] > 0)}; never interpolated across")
        if m["windows_dropped_gap"] or m["windows_dropped_unsteady"]:
            parts.append(f"  dropped windows: {int(m['windows_dropped_gap'])} spanning a gap, "
                         f"{int(m['windows_dropped_unsteady'])} unsteady (--steady-only)")
        if m["partition_tail_s"]:
            parts.append(f"  not windowed: {m['partition_tail_s']:.1f} s of run tails after "
                         f"the last full partition (partition protocol) in "
                         f"{ids(t['partition_tail_s'] > 0)}")
        if m["window_tail_s"]:
            parts.append(f"  not windowed: {m['window_tail_s']:.1f} s of run tails after "
                         f"the last full window in {ids(t['window_tail_s'] > 0)}")
        if m["between_windows_s"]:
            parts.append(f"  not windowed: {m['between_windows_s']:.1f} s between windows (a "
                         f"hop longer than the window) in {ids(t['between_windows_s'] > 0)}")
        if m["windows_empty_gap"]:
            parts.append(f"  {int(m['windows_empty_gap'])} window position(s) wholly inside "
                         "a gap of every stream: no data there, not counted as dropped")
        for status in ("skipped", "too_short"):
            for reason, group in t[t["status"] == status].groupby("reason", sort=False):
                word = "skipped" if status == "skipped" else "too short"
                parts.append(f"  {len(group)} run(s) {word} ({reason}): "
                             f"{_short(list(group['run_id']), limit)}")
        if m["stuck_channels"]:
            per = (t.loc[t["stuck"] != "", ["run_id", "stuck"]]
                   .apply(lambda r: f"{r.run_id} ({r.stuck})", axis=1))
            parts.append(f"  stuck or dead sensor channel(s): {_short(list(per), limit)}"
                         + (f"; {int(m['windows_flagged'])} window(s) holding one flagged"
                            if m["windows_flagged"] else ""))
        if m["warnings"]:
            parts.append(f"  {int(m['warnings'])} plausibility warning(s), printed above")
        if len(parts) == 1:
            parts[0] += "; nothing repaired, dropped or skipped"
        return "\n".join(parts)


def input_report(runs: Sequence[Run], counts: Mapping[str, Any] | None = None,
                 window_s: float | None = None,
                 flagged: Mapping[str, int] | None = None) -> InputReport:
    """Build the report of the runs a command read and windowed.

    Parameters
    ----------
    runs : sequence of Run
        The runs read (their ``meta`` holds what the readers repaired and noticed).
    counts : Mapping, optional
        ``WindowSet.counts`` of :func:`features.windows.make_windows` (or the same keys:
        ``per_run``, ``skipped_runs``, ``too_short_runs``; ``empty_gap``, the window
        positions wholly inside a gap, ``partition_tail_s``, ``window_tail_s`` and
        ``between_windows_s`` may be
        absent from a ``per_run`` entry, and ``reasons``, run id -> why it was skipped or
        is too short, from ``counts``; ``streams``, the streams the command aligned, from
        :func:`features.windows.required_streams` of its channels). Without it (or a run
        without its ``per_run`` entry) ``windows`` is -1 and the other window columns 0.
        Only where both streams are aligned is each cut to the other's span: with one (a
        wheel-only model) all of it is used and the other not at all, so no
        ``unused_*_s`` is counted; without ``streams`` the readers' account is kept.
    window_s : float, optional
        Window length, s (for the too-short reason where ``counts`` gives none).
    flagged : Mapping[str, int], optional
        Run id -> windows flagged for holding a stuck sensor.

    Returns
    -------
    InputReport
    """
    counts = counts or {}
    per_run = counts.get("per_run", {})
    skipped = set(counts.get("skipped_runs", ()))
    short = set(counts.get("too_short_runs", ()))
    reasons = dict(counts.get("reasons", {}))
    flagged = flagged or {}
    aligned = set(UNUSED_STREAMS) <= set(counts.get("streams", UNUSED_STREAMS))
    rows = []
    for run in runs:
        meta = run.meta
        repaired = dict(meta.get("repaired", {}))
        gaps = merged_gaps(dict(meta.get("gaps", {})))
        stuck = sorted(dict(meta.get("stuck", {})))
        unused = dict(meta.get("unused_s", {})) if aligned else {}
        w = per_run.get(run.run_id)
        status, reason = "used", ""
        if run.run_id in skipped:
            missing = sorted({"imu", "wheels"} - set(run.streams))
            status = "skipped"
            reason = reasons.get(run.run_id) or (f"no {' or '.join(missing)} stream"
                                                 if missing
                                                 else "lacks a stream the signals need")
        elif run.run_id in short:
            status = "too_short"
            reason = reasons.get(run.run_id) or ("shorter than one window" if window_s is None
                                                 else f"shorter than one {window_s:g} s window")
        rows.append({
            "run_id": run.run_id, "status": status, "reason": reason,
            "repaired_cells": int(sum(repaired.values())),
            "repaired": ", ".join(f"{k}:{v}" for k, v in repaired.items()),
            "gaps": len(gaps), "gap_s": float(sum(b - a for a, b in gaps)),
            "gap_list": ";".join(f"{a:.3f}..{b:.3f}" for a, b in gaps),
            "skipped_lines": int(sum(dict(meta.get("skipped_lines", {})).values())),
            "ignored_columns": ",".join(f"{stream}.{c}" for stream, cols in
                                        dict(meta.get("ignored_columns", {})).items()
                                        for c in cols),
            **{f"unused_{k}_s": float(unused.get(k, 0.0)) for k in UNUSED_STREAMS},
            "stuck": ",".join(stuck),
            "windows": int(w["windows"]) if w else -1,
            "dropped_gap": int(w["dropped_gap"]) if w else 0,
            "empty_gap": int(w.get("empty_gap", 0)) if w else 0,
            "dropped_unsteady": int(w["dropped_unsteady"]) if w else 0,
            "partition_tail_s": float(w.get("partition_tail_s", 0.0)) if w else 0.0,
            "window_tail_s": float(w.get("window_tail_s", 0.0)) if w else 0.0,
            "between_windows_s": float(w.get("between_windows_s", 0.0)) if w else 0.0,
            "flagged_windows": int(flagged.get(run.run_id, 0)),
            "warnings": len(meta.get("warnings", ())),
        })
    return InputReport(pd.DataFrame(rows, columns=list(COLUMNS)))


def merged_gaps(gaps: Mapping[str, Sequence]) -> list[tuple[float, float]]:
    """The timestamp gaps of a run's streams as one sorted list, overlapping ones merged.

    A hole in the recording shows in every stream file; counted per stream it would count
    (and sum) once per file.

    Parameters
    ----------
    gaps : Mapping[str, sequence]
        ``Run.meta["gaps"]``: stream -> ``[(t_start_s, t_end_s), ...]`` (s).

    Returns
    -------
    list of tuple
        ``(t_start_s, t_end_s)`` of each stretch in which at least one stream has a gap,
        sorted, disjoint.
    """
    out: list[list[float]] = []
    for a, b in sorted((float(a), float(b)) for spans in gaps.values() for a, b in spans):
        if out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(a, b) for a, b in out]


def _short(items: list[str], limit: int) -> str:
    more = f" and {len(items) - limit} more" if len(items) > limit else ""
    return ", ".join(items[:limit]) + more
