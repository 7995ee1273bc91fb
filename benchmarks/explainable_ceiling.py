"""What one parameter set per terrain can reach on BorealTC: the ceilings of issue 14's targets.

Replays every BorealTC run with physics v1 (reference) and v2 (candidate) on one comparison
clock (:func:`terrain.audit.physics.paired_frames`), splits each terrain's runs as the
physics-v2 parameters were chosen (:func:`terrain.audit.physics.alternate_split`: training
half / held-out half) and computes, per terrain and pooled (every terrain with its own fit):

* ``shared``: the best steady model with one parameter set per terrain, fitted on the
  evaluated runs themselves (yaw rate: one ICR expansion factor per manoeuvre; current: an
  affine recalibration of both physics' currents with side speed and yaw-rate terms);
* ``per_run``: the same family fitted per run (the ground state of every run known);
* ``trained``: the same family fitted on the training half of the terrain's runs and scored
  on the held-out half: the family's parameter set chosen as the targets' parameters are;
* ``learned``: a gradient-boosted map from the wheel-speed history and both physics'
  predictions, trained on the training half, scored on the held-out half;
* ``online``: v2 with each run's chi (yaw rate) or current offset (currents) estimated
  causally from its own measurements, forecast 2 s ahead
  (:func:`terrain.audit.ceiling.online_yaw_rate_samples`,
  :func:`~terrain.audit.ceiling.online_current_samples`; memory and prior weight chosen on
  the training halves per signal, all terrains pooled; the yaw rate also reported 5 and 10 s
  ahead). Not a replay without fitted effects: it shows what estimating the ground state
  per run gives.

(:mod:`terrain.audit.ceiling`.) Prints the tables, writes them as CSV, draws the figure
(held-out yaw-rate gains per terrain; SNOW spin current per run against the commanded spin
rate), prints the outer and inner motor currents in curves per terrain and the
least-squares chi per terrain and manoeuvre of the measured yaw rate and of both replays on
the same samples (``chi_shared.csv``), and logs the gains, tables and figure to MLflow
(experiment ``terrain-benchmark``, run ``explainable-ceiling``).
``docs/physics_v2.md``, section "What one parameter set per terrain can reach".

Usage: ``python benchmarks/explainable_ceiling.py [--dataset borealtc|vulpi]
[--out docs/physics_v2_ceiling.csv] [--figure docs/physics_v2_ceiling.png]``
(about 4 min: two replays of 55 runs).
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from pipelines.arguments import output_file
from terrain.audit.ceiling import (ceiling_table, current_ceiling_samples,
                                   learned_transfer_samples, online_current_samples,
                                   online_yaw_rate_samples, yaw_rate_ceiling_samples)
from terrain.audit.frames import MANOEUVRES
from terrain.audit.physics import PhysicsComparisonSettings, alternate_split, paired_frames
from terrain.errors import ConfigError
from terrain.io.shipped import load_dataset
from terrain.tracking import require_store, tracked_run
from terrain.vehicles.icr import icr_expansion_factor


def _tables(samples: dict[str, list[pd.DataFrame]], runs: str) -> list[pd.DataFrame]:
    """Per terrain and pooled ("all"), the ceiling table of each signal's sample tables."""
    out = []
    for signal, parts in samples.items():
        parts = [p for p in parts if not p.empty]
        if not parts:
            continue
        groups = {t: [p for p in parts if p.terrain.iloc[0] == t]
                  for t in sorted({p.terrain.iloc[0] for p in parts})}
        groups["all"] = parts
        for terrain, ps in groups.items():
            tab = ceiling_table(pd.concat(ps, ignore_index=True))
            tab.insert(0, "signal", signal)
            tab.insert(0, "terrain", terrain)
            tab.insert(0, "runs", runs)
            out.append(tab)
    return out


#: forecast horizon of the online chi (fixed, not tuned), s, and the horizons also reported
ONLINE_LEAD_S = 2.0
ONLINE_LEADS_REPORTED = (2.0, 5.0, 10.0)
#: settings of the online chi searched on the training halves (all terrains pooled)
ONLINE_GRID = {"memory_s": (15.0, 30.0, 60.0, 120.0), "prior_s": (0.0, 2.0, 5.0, 10.0, 20.0)}


#: the online estimate of each signal group
ONLINE = {"wz": online_yaw_rate_samples, "cur": online_current_samples}


def _online(groups, lead_s: float, memory_s: float, prior_s: float,
            signal: str = "wz") -> list[pd.DataFrame]:
    """Online sample tables (chi or current offset) of several terrains' (frame, candidate)
    pairs."""
    return [ONLINE[signal]([p[0] for p in g], [p[1] for p in g], lead_s=lead_s,
                           memory_s=memory_s, prior_s=prior_s) for g in groups]


def _moving_gain(parts: list[pd.DataFrame]) -> float:
    """Pooled gain of the ``online`` column over moving samples."""
    tab = ceiling_table(pd.concat([p for p in parts if not p.empty], ignore_index=True))
    return float(tab[tab.scope == "moving"].gain_online.iloc[0])


def choose_online_settings(train_groups, signal: str = "wz") -> tuple[dict, pd.DataFrame]:
    """The online setting with the best pooled gain of ``signal`` on the training halves."""
    rows = []
    for memory_s in ONLINE_GRID["memory_s"]:
        for prior_s in ONLINE_GRID["prior_s"]:
            gain = _moving_gain(_online(train_groups, ONLINE_LEAD_S, memory_s, prior_s, signal))
            rows.append({"signal": signal, "memory_s": memory_s, "prior_s": prior_s,
                         "train_gain": gain})
    grid = pd.DataFrame(rows)
    best = grid.loc[grid.train_gain.idxmax()]
    return {"memory_s": float(best.memory_s), "prior_s": float(best.prior_s)}, grid


def _add_online(samples: dict[str, list[pd.DataFrame]], online: list[pd.DataFrame],
                signal: str = "wz") -> None:
    """Put the ``online`` column beside the ceiling samples (same samples, same order)."""
    for tab, on in zip(samples[signal], online):
        if len(tab) != len(on) or not np.array_equal(tab.measured.to_numpy(),
                                                     on.measured.to_numpy()):
            raise RuntimeError("online and ceiling samples differ")
        tab["online"] = on["online"].to_numpy()


def _merge_learned(base: list[pd.DataFrame], learned: list[pd.DataFrame]) -> pd.DataFrame:
    """Add the learned columns to the held-out rows (same samples, same reference RMSE)."""
    b = pd.concat(base, ignore_index=True)
    if not learned:
        return b
    keys = ["runs", "terrain", "signal", "scope"]
    lt = pd.concat(learned, ignore_index=True)[keys + ["n", "rmse_learned", "gain_learned"]]
    m = b.merge(lt, on=keys, how="left", suffixes=("", "_learned"))
    bad = m.n_learned.notna() & (m.n_learned != m.n)
    if bad.any():
        raise RuntimeError(f"learned and ceiling samples differ: {m[bad][keys]}")
    return m.drop(columns="n_learned")


def _spin_runs(pairs, terrain: str) -> pd.DataFrame:
    """Per run of a terrain, its spin samples: commanded |x|, measured chi and currents."""
    rows = []
    for ref, cand in pairs:
        m = ref.score_cur & (ref.manoeuvre == MANOEUVRES.index("spin"))
        if ref.terrain != terrain or m.sum() < 20:
            continue
        mi = m & ref.score_imu & np.isfinite(ref.wz)
        chi = (icr_expansion_factor(ref.wz[mi], ref.commanded_yaw_rate[mi]) if mi.sum() >= 20
               else np.nan)
        rows.append((ref.run_id, float(np.abs(ref.commanded_yaw_rate[m]).mean()), chi,
                     float(ref.cur[m].mean()), float(ref.sim_cur[m].mean()),
                     float(cand.sim_cur[m].mean())))
    return pd.DataFrame(rows, columns=["run_id", "x_abs_rad_s", "chi_measured", "cur_measured_a",
                                       "cur_v1_a", "cur_v2_a"])


def curve_current_split(pairs) -> pd.DataFrame:
    """Per terrain, mean outer and inner motor current over forward-curve samples.

    Runs with at least 30 scored forward-curve samples; outer = the faster side. Columns
    ``terrain, runs`` and ``{outer,inner}_{measured,v1,v2}_a`` (A).
    """
    acc: dict[str, dict[str, list]] = {}
    for ref, cand in pairs:
        m = ref.score_cur & (ref.manoeuvre == MANOEUVRES.index("curve")) & \
            (ref.commanded_speed > 0)
        if m.sum() < 30:
            continue
        outer = (ref.commanded_yaw_rate[m] > 0).astype(int)   # turning left: right is outer
        idx = np.arange(int(m.sum()))
        d = acc.setdefault(ref.terrain, {"runs": []})
        d["runs"].append(ref.run_id)
        for name, cur in (("measured", ref.cur[m]), ("v1", ref.sim_cur[m]),
                          ("v2", cand.sim_cur[m])):
            d.setdefault(f"outer_{name}_a", []).append(cur[idx, outer])
            d.setdefault(f"inner_{name}_a", []).append(cur[idx, 1 - outer])
    rows = []
    for terrain, d in sorted(acc.items()):
        row = {"terrain": terrain, "runs": len(d.pop("runs"))}
        row.update({k: float(np.concatenate(v).mean()) for k, v in d.items()})
        rows.append(row)
    return pd.DataFrame(rows)


def ceiling_figure(table: pd.DataFrame, spins: pd.DataFrame) -> Figure:
    """(a) Held-out yaw-rate gain over v1 per terrain: v2, the shared ceiling, per run, online;
    (b) SNOW spins: mean current per run against the commanded spin rate."""
    fig = Figure(figsize=(11, 4))
    ax, bx = fig.subplots(1, 2)
    held = table[(table.runs == "held-out") & (table.signal == "wz") & (table.scope == "moving")]
    pos = np.arange(len(held))
    bars = (("gain_candidate", "v2"), ("gain_shared", "one chi per manoeuvre (ceiling)"),
            ("gain_trained", "one chi per manoeuvre, fitted on the training runs"),
            ("gain_per_run", "one chi per run"),
            ("gain_online", f"v2 + chi estimated online, {ONLINE_LEAD_S:.0f} s ahead"))
    for k, (col, label) in enumerate(bars):
        ax.bar(pos + (k - 2) * 0.16, 100 * held[col], 0.16, label=label)
    ax.axhline(40, color="k", ls="--", lw=0.8)
    ax.text(-0.4, 41, "SNOW, SANDY_LOAM target 40 %", fontsize=8)
    ax.axhline(25, color="k", ls=":", lw=0.8)
    ax.text(-0.4, 26, "all-terrain target 25 %", fontsize=8)
    ax.set_xticks(pos, held.terrain, rotation=20)
    ax.set_ylabel("yaw-rate RMSE cut over v1, held-out runs (%)")
    ax.set_title("(a) yaw rate, held-out runs")
    ax.set_ylim(top=150)
    ax.legend(fontsize=7, loc="upper center", ncol=2)
    if spins.empty:
        bx.text(0.5, 0.5, "no SNOW spins in this dataset", ha="center", transform=bx.transAxes)
        bx.set_axis_off()
        fig.tight_layout()
        return fig
    dug = spins.chi_measured > 3
    bx.scatter(spins.x_abs_rad_s[dug], spins.cur_measured_a[dug], c="tab:red",
               label="measured, dug in (chi > 3)")
    bx.scatter(spins.x_abs_rad_s[~dug], spins.cur_measured_a[~dug], c="tab:green",
               label="measured, turning (chi <= 3)")
    order = np.argsort(spins.x_abs_rad_s.to_numpy())
    bx.plot(spins.x_abs_rad_s.to_numpy()[order], spins.cur_v1_a.to_numpy()[order], "k.-",
            label="v1 replay")
    bx.plot(spins.x_abs_rad_s.to_numpy()[order], spins.cur_v2_a.to_numpy()[order], "b.--",
            label="v2 replay")
    bx.set_xlabel("commanded spin rate |x| (rad/s), run mean")
    bx.set_ylabel("motor current (A), run mean over spin samples")
    bx.set_title("(b) SNOW spins, per run")
    bx.legend(fontsize=8)
    fig.tight_layout()
    return fig


def main() -> int:
    ap = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", choices=("borealtc", "vulpi"), default="borealtc",
                    help="shipped dataset (Husky runs)")
    ap.add_argument("--out", type=output_file, default=None,
                    help="CSV of the tables (default docs/physics_v2_ceiling[_vulpi].csv)")
    ap.add_argument("--figure", type=output_file, default=None,
                    help="PNG of the figure (default docs/physics_v2_ceiling[_vulpi].png)")
    ap.add_argument("--no-mlflow", action="store_true", help="do not log to MLflow")
    args = ap.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    suffix = "" if args.dataset == "borealtc" else f"_{args.dataset}"
    args.out = args.out or f"docs/physics_v2_ceiling{suffix}.csv"
    args.figure = args.figure or f"docs/physics_v2_ceiling{suffix}.png"
    runs = load_dataset(args.dataset)
    settings = PhysicsComparisonSettings()
    pairs, skipped = paired_frames(runs, settings)
    if skipped:
        print(f"skipped {len(skipped)} run(s): {skipped}")
    by_terrain: dict[str, list] = {}
    for ref, cand in pairs:
        by_terrain.setdefault(ref.terrain, []).append((ref, cand))
    held: dict[str, list[pd.DataFrame]] = {"wz": [], "cur": []}
    every: dict[str, list[pd.DataFrame]] = {"wz": [], "cur": []}
    learned: dict[str, list[pd.DataFrame]] = {"wz": [], "cur": []}
    chi_rows = []
    split_ids = {}
    for terrain, tp in sorted(by_terrain.items()):
        ids_train, ids_held = ({r.run_id for r in half} for half in alternate_split(
            [r for r in runs if r.terrain == terrain]))
        split_ids[terrain] = (ids_train, ids_held)
        train = [p for p in tp if p[0].run_id in ids_train]
        test = [p for p in tp if p[0].run_id in ids_held]
        tr_f, tr_c = [p[0] for p in train], [p[1] for p in train]
        te_f, te_c = [p[0] for p in test], [p[1] for p in test]
        for name, group, store in (("held-out", test, held), ("all", tp, every)):
            f, c = [p[0] for p in group], [p[1] for p in group]
            held_out = name == "held-out"     # the `trained` column: fitted on the training half
            wz = yaw_rate_ceiling_samples(f, c, train_frames=tr_f if held_out else None)
            store["wz"].append(wz)
            store["cur"].append(current_ceiling_samples(
                f, c, train_frames=tr_f if held_out else None,
                train_candidates=tr_c if held_out else None))
            for man, chi in wz.attrs.get("chi_shared", {}).items():
                chi_rows.append((name, terrain, man, chi,
                                 wz.attrs.get("chi_trained", {}).get(man, np.nan),
                                 wz.attrs["chi_reference"][man], wz.attrs["chi_candidate"][man]))
        try:
            learned["wz"].append(learned_transfer_samples(tr_f, te_f, "wz", tr_c, te_c))
        except ConfigError as exc:  # no IMU in the training half: reported, not fatal
            print(f"{terrain}: learned yaw transfer not run ({exc})")
        cur = [learned_transfer_samples(tr_f, te_f, s, tr_c, te_c) for s in ("cur_l", "cur_r")]
        learned["cur"].append(pd.concat(cur, ignore_index=True))
        print(f"{terrain}: {len(train)} training, {len(test)} held-out runs", flush=True)
    terrains = sorted(by_terrain)
    groups = {name: [[p for p in by_terrain[t] if p[0].run_id in split_ids[t][k]]
                     for t in terrains] for k, name in enumerate(("train", "held-out"))}
    chosen, grids, held_online = {}, [], {}
    for signal in ("wz", "cur"):
        chosen[signal], grid = choose_online_settings(groups["train"], signal)
        grids.append(grid)
        held_online[signal] = _online(groups["held-out"], ONLINE_LEAD_S, **chosen[signal],
                                      signal=signal)
        _add_online(held, held_online[signal], signal)
        _add_online(every, _online([by_terrain[t] for t in terrains], ONLINE_LEAD_S,
                                   **chosen[signal], signal=signal), signal)
    online_grid = pd.concat(grids, ignore_index=True)
    online_settings = chosen["wz"]
    print("online estimates, training halves (lead %.0f s):" % ONLINE_LEAD_S)
    print(online_grid.round(3).to_string(index=False))
    print(f"chosen: {chosen}")
    leads = []
    for lead in ONLINE_LEADS_REPORTED:
        parts = (held_online["wz"] if lead == ONLINE_LEAD_S
                 else _online(groups["held-out"], lead, **online_settings))
        snow = [p for p in parts if not p.empty and p.terrain.iloc[0] == "SNOW"]
        leads.append({"lead_s": lead, "all": _moving_gain(parts),
                      "SNOW": _moving_gain(snow) if snow else np.nan})
    leads = pd.DataFrame(leads)
    print("online chi, held-out yaw-rate gain over v1 by forecast horizon:")
    print(leads.round(3).to_string(index=False))
    table = _merge_learned(_tables(held, "held-out") + _tables(every, "all"),
                           _tables(learned, "held-out"))
    table.to_csv(args.out, index=False)
    chi = pd.DataFrame(chi_rows, columns=["runs", "terrain", "manoeuvre", "chi_shared",
                                          "chi_trained", f"chi_{settings.reference}_replay",
                                          f"chi_{settings.candidate}_replay"])
    pd.set_option("display.width", 200)
    show = ["runs", "terrain", "signal", "scope", "n_runs", "rmse_reference", "gain_candidate",
            "gain_shared", "gain_trained", "gain_per_run", "gain_online", "gain_learned"]
    print(table[show].round(3).to_string(index=False))
    print(chi.round(2).to_string(index=False))
    split = curve_current_split(pairs)
    print(split.round(1).to_string(index=False))
    spins = _spin_runs(pairs, "SNOW")   # empty on datasets without snow
    print(spins.round(2).to_string(index=False))
    fig = ceiling_figure(table, spins)
    fig.savefig(args.figure, dpi=110)
    print(f"-> {args.out}, {args.figure}")
    if not args.no_mlflow:
        with tracked_run("terrain-benchmark", "explainable-ceiling",
                         {"dataset": args.dataset, "reference": settings.reference,
                          "candidate": settings.candidate}) as run:
            metrics = {}
            for row in table.itertuples(index=False):
                for col in ("gain_candidate", "gain_shared", "gain_trained", "gain_per_run",
                            "gain_online", "gain_learned"):
                    v = getattr(row, col, np.nan)
                    if np.isfinite(v):
                        metrics[f"{row.runs}.{row.terrain}.{row.signal}.{row.scope}.{col}"] = \
                            float(v)
            run.log_metrics(metrics)
            run.log_table(table, "explainable_ceiling.csv")
            run.log_table(chi, "chi_shared.csv")
            run.log_table(spins, "snow_spin_runs.csv")
            run.log_table(split, "curve_current_split.csv")
            run.log_table(online_grid, "online_chi_grid.csv")
            run.log_table(leads, "online_chi_leads.csv")
            run.log_params({f"online_{sig}_{k}": v for sig, c in chosen.items()
                            for k, v in c.items()})
            run.log_artifact(args.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
