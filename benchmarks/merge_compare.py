"""Merge ``terrain compare`` output folders and add the equal-weight soft vote of members.

Each folder holds ``compare_cells.csv`` and ``predictions.csv`` of some cells (e.g. one model
and one seed per folder, run in parallel). Cells are concatenated; for every (dataset,
signals, window, seed) where all ``--vote`` members are present, their out-of-fold
probabilities are averaged with equal weights (:func:`terrain.models.compare.soft_vote`,
identical to the fixed-weight :class:`~terrain.models.ensemble.SoftVotingEnsemble` on the
same folds) and scored as model ``vote(<members>)`` (where a member is missing, the vote is
left out and a note says how often); folders run under other folds (``n_splits``,
``single_run_blocks``) or, for one model, other CNN training (``max_epochs``,
``early_stopping``, ``cnn_seeds``) are refused; its train time is the members' sum and
its inference time the sum of theirs. Writes ``compare_table.md/.csv``, ``compare.png``
(and ``compare_grid.png`` / ``compare_grid.md``, signal set x window, when the folders span
several signal sets or windows) and
``compare_cells.csv`` (one row per cell, seed and history, the votes included) to ``--out``.

Run: ``python benchmarks/merge_compare.py DIR... --vote svm cnn cnn-spectrogram --out DIR``
(repeat ``--vote`` for several member sets: ``--vote svm cnn-spectrogram --vote svm cnn
cnn-spectrogram``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from pipelines.arguments import DistinctValues, output_dir, positive_integer
from terrain.models.compare import (CNN_SETTINGS, PROTOCOL_SETTINGS, grid_markdown,
                                    markdown_table, plot_comparison, plot_grid, score_rows,
                                    soft_vote, spans_grid, summary_table, with_default_keys)


def _read(path: Path) -> pd.DataFrame:
    """Read one folder's CSV; folders written before the protocol or training-hop columns
    are ``grouped`` with non-overlapping training windows.

    Parameters
    ----------
    path : Path
        ``compare_cells.csv`` or ``predictions.csv`` of one ``terrain compare`` folder.

    Returns
    -------
    pandas.DataFrame
        The table with ``protocol`` and ``train_hop_s`` columns (filled per folder, so that
        folders with and without them can be merged without NaN keys).
    """
    return with_default_keys(pd.read_csv(path))


def _cells_in_several_folders(cells: pd.DataFrame, keys: list[str]) -> list[str]:
    """Name every cell that more than one folder holds.

    Parameters
    ----------
    cells : pandas.DataFrame
        The folders' ``compare_cells.csv`` rows, with a ``folder`` column.
    keys : list of str
        Columns that, with ``model``, identify one cell (whatever histories it was scored
        at: a cell's rows at other histories in another folder are the same predictions).

    Returns
    -------
    list of str
        One line per duplicated cell: its model, keys and the folders holding it (empty
        when every cell is in one folder).
    """
    ident = ["model", *keys]
    folders = cells.groupby(ident, dropna=False)["folder"].agg(lambda f: sorted(set(f)))
    return [f"{key[0]} ({', '.join(f'{k} {v}' for k, v in zip(ident[1:], key[1:]))}): "
            + ", ".join(where) for key, where in folders.items() if len(where) > 1]


def _shown(value) -> str:
    """A setting as typed (a CSV column with gaps reads 30 as 30.0)."""
    return f"{value:g}" if isinstance(value, float) else str(value)


def _settings_conflicts(cells: pd.DataFrame) -> tuple[list[str], list[str]]:
    """Name every setting that the folders ran under differently.

    The folds (``n_splits``, ``single_run_blocks``) must be one for all folders: a vote
    averages its members window by window and the table pools seeds. A CNN's training
    (``max_epochs``, ``early_stopping``, ``cnn_seeds``) must be one per model.

    Parameters
    ----------
    cells : pandas.DataFrame
        The folders' ``compare_cells.csv`` rows, with a ``folder`` column.

    Returns
    -------
    conflicts : list of str
        One line per setting (and model) given different values, naming each value's
        folders.
    unchecked : list of str
        Folders that record none of the fold settings (written before
        :func:`terrain.models.compare.protocol_settings`), not checked.
    """
    conflicts = []
    for setting in PROTOCOL_SETTINGS + CNN_SETTINGS:
        if setting not in cells:
            continue
        known = cells.dropna(subset=[setting])
        groups = (known.groupby("model", sort=True) if setting in CNN_SETTINGS
                  else [(None, known)])
        for model, frame in groups:
            folders = frame.groupby(setting, sort=True)["folder"].unique()
            if len(folders) > 1:
                where = f" of {model}" if model is not None else ""
                conflicts.append(f"{setting}{where}: " + "; ".join(
                    f"{_shown(v)} in {', '.join(sorted(f))}" for v, f in folders.items()))
    recorded = [s for s in PROTOCOL_SETTINGS if s in cells]
    unchecked = sorted(set(cells["folder"]) - set(
        cells.dropna(subset=recorded, how="all")["folder"] if recorded else ()))
    return conflicts, unchecked


def main() -> int:
    """Merge the folders, add the vote, write the table and figure."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", action=DistinctValues, type=Path)
    parser.add_argument("--vote", nargs="+", action="append", default=None,
                        help="members of one equal-weight vote; repeat for several votes "
                             "(default: svm cnn cnn-spectrogram)")
    parser.add_argument("--history", type=positive_integer, nargs="+", action=DistinctValues,
                        default=[1, 5, 10])
    parser.add_argument("--out", type=output_dir, required=True)
    args = parser.parse_args()
    keys = ["protocol", "dataset", "signals", "window_s", "train_hop_s", "seed"]
    cells = pd.concat([_read(d / "compare_cells.csv").assign(folder=str(d))
                       for d in args.dirs])
    twice = _cells_in_several_folders(cells, keys)
    if twice:
        parser.error("a cell is in more than one folder (it would count as several seeds); "
                     "pass one folder per cell:\n  " + "\n  ".join(twice))
    conflicts, unchecked = _settings_conflicts(cells)
    if conflicts:
        parser.error("the folders ran under other settings (their seeds and votes would mix "
                     "protocols); merge folders of one setting:\n  " + "\n  ".join(conflicts))
    if unchecked:
        print(f"note: {', '.join(unchecked)} record no fold or training settings (written "
              "before they were recorded): not checked against the other folders")
    cells = cells.drop(columns="folder")
    preds = pd.concat([_read(d / "predictions.csv") for d in args.dirs])
    rows = [cells]
    for vote in args.vote or [["svm", "cnn", "cnn-spectrogram"]]:
        name = "vote(" + "+".join(vote) + ")"
        left_out, missing = 0, set()
        for key, frame in preds.groupby(keys):
            members = [frame[frame["model"] == m] for m in vote]
            if any(m.empty for m in members):   # counted and said below
                left_out += 1
                missing.update(m for m, f in zip(vote, members) if f.empty)
                continue
            # folders of several datasets: only this dataset's probability columns are filled
            classes = [c[6:] for c in frame.columns
                       if c.startswith("proba_") and frame[c].notna().all()]
            voted = soft_vote(members, classes)
            # a cell's times are the same in each of its history rows: one row per member
            sub = cells[(cells[keys] == pd.Series(key, index=keys)).all(axis=1)
                        & cells["model"].isin(vote)].drop_duplicates("model")
            fields = {**dict(zip(keys, key)), "model": name,
                      "fit_s_per_fold": float(sub["fit_s_per_fold"].sum()),
                      "infer_ms_per_window": float(sub["infer_ms_per_window"].sum())}
            rows.append(pd.DataFrame(score_rows(voted, classes, args.history, fields)))
        if left_out:
            print(f"note: {name} left out at {left_out} of {preds.groupby(keys).ngroups} "
                  f"({', '.join(keys)}): no {', '.join(sorted(missing))} predictions there")
    per_seed = pd.concat(rows, ignore_index=True)
    table = summary_table(per_seed)
    args.out.mkdir(parents=True, exist_ok=True)
    per_seed.to_csv(args.out / "compare_cells.csv", index=False)
    md = markdown_table(table)
    (args.out / "compare_table.md").write_text(md)
    table.to_csv(args.out / "compare_table.csv", index=False)
    plot_comparison(table).savefig(args.out / "compare.png", dpi=120)
    if spans_grid(table):
        plot_grid(table).savefig(args.out / "compare_grid.png", dpi=120, bbox_inches="tight")
        (args.out / "compare_grid.md").write_text(grid_markdown(table, args.history))
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
