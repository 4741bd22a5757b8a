#!/usr/bin/env python3
"""Tables and the Fig 8 comparison of pipelines/studies/PHYSICAL_WEBS.md, read from the
archives of pipelines/studies/physical_vs_surrogate.yaml, table4_physical.yaml and
uniformity_drivers.yaml.

Usage (from the repository root, after running the pipelines):
    .venv/bin/python scripts/physical_webs_table.py [--figure] [--drivers]
Needs h5py and numpy (tests/python/requirements.txt); --figure also needs matplotlib.
"""
import os
import sys

import h5py
import numpy as np

STUDY = "results/physical_vs_surrogate.h5"
TABLE4 = "results/table4_physical.h5"
DRIVERS = "results/uniformity_drivers.h5"
FIGURES = "pipelines/studies/figures"


def current(f, stage):
    """The stage's current version (layout 2), else its newest vN (an archive migrated from
    layout 1 by a `--only` run keeps unmarked stages)."""
    if "current" in f[stage].attrs:
        return f[stage][f[stage].attrs["current"]]
    newest = max((k for k in f[stage] if k.startswith("v") and k[1:].isdigit()), key=lambda k: int(k[1:]))
    return f[stage][newest]


def ms(a, scale=1.0, digits=2):
    a = np.asarray(a, dtype=float) * scale
    a = a[np.isfinite(a)]
    if a.size == 0:
        return "–"
    if a.size == 1:
        return f"{a[0]:.{digits}f}"
    return f"{a.mean():.{digits}f} ± {a.std(ddof=1):.{digits}f}"


def swept(group, name):
    """A swept parameter's values per point (stored as `name` or `sweep_<name>`)."""
    for key in (name, f"sweep_{name}"):
        if key in group:
            return group[key][...]
    raise KeyError(f"{group.name} has no swept {name}")


def zone_index(zones, size):
    return int(np.argmin(np.abs(np.asarray(zones) - size)))


def grid_row(g, p):
    """ρ_av, CV (%), n_f at 1 and 10 mm of grid point p, over realisations."""
    zones = g["zone_size"][...]
    nf = g["formation_number"][p]  # (realisation, zone)
    i1, i10 = zone_index(zones, 1e-3), zone_index(zones, 10e-3)
    return [
        ms(g["mean_areal_density"][p]),
        ms(g["cv"][p], 100.0, 1),
        ms(nf[:, i1]),
        ms(nf[:, i10]),
    ], (zones[i1], zones[i10])


def study_table():
    f = h5py.File(STUDY, "r")
    laid, lg = current(f, "laid"), current(f, "laid_grid")
    amps = swept(laid, "oscillation_amplitude")
    c = laid["belt_speed_ratio"][...]
    print("| u0 (mm) | c | web | S belt removed (mm) | ρ_av (g/m²) | CV (%) | n_f 1 mm | n_f 11 mm | time per web (s) |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|")
    for p in range(len(c)):
        tag = f"u{int(round(amps[p] * 1000))}_c{int(round(c[p] * 100)):03d}"
        sg = current(f, f"surrogate_{tag}_grid")
        lrow, zones = grid_row(lg, p)
        srow, _ = grid_row(sg, 0)
        valid = laid["valid"][p].astype(bool)
        s_laid = laid["radius_of_gyration_belt_removed"][p][valid]
        wall = np.nansum(laid["wall_seconds"][p], axis=-1)
        sw = current(f, f"surrogate_{tag}").attrs.get("wall_seconds", np.nan) + np.nansum(sg["wall_seconds"][0])
        print(f"| {amps[p] * 1e3:g} | {c[p]:g} | laid | {ms(s_laid, 1e3)} | " + " | ".join(lrow) + f" | {ms(wall, 1, 0)} (CPU) |")
        print(f"| | | surrogate | – | " + " | ".join(srow) + f" | {sw / 5:.2f} |")
    print(f"\nzone sizes used: {zones[0] * 1e3:g} mm and {zones[1] * 1e3:g} mm; "
          f"interior density expected ρA/(Δw·c): " + ", ".join(f"{v:.2f}" for v in lg["expected_interior_density"][...]) + " g/m²")


def generators_table():
    """The three surrogates of the same laid fibres against the laid web (issue 14)."""
    f = h5py.File(STUDY, "r")
    laid, lg = current(f, "laid"), current(f, "laid_grid")
    amps = swept(laid, "oscillation_amplitude")
    c = laid["belt_speed_ratio"][...]
    print("| u0 (mm) | c | web | S of a segment (mm) | e of a segment | ρ_av (g/m²) | CV (%) | CV / laid CV | n_f 1 mm | n_f 11 mm | calibrated b (mm), A (m^-1/2) |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---|")
    for p in range(len(c)):
        tag = f"u{int(round(amps[p] * 1000))}_c{int(round(c[p] * 100)):03d}"
        lrow, _ = grid_row(lg, p)
        laid_cv = np.nanmean(lg["cv"][p])
        first = True
        for name, web in (("laid", None), ("random_phase", "surrogate"), ("laid_segments", "segments"), ("lay_down_sde", "sde")):
            if web is None:
                row, s, e, extra, ratio = lrow, "", "", "", ""
            else:
                w, g = current(f, f"{web}_{tag}"), current(f, f"{web}_{tag}_grid")
                row, _ = grid_row(g, 0)
                s = f"{w['generated_radius_of_gyration'][0] * 1e3:.2f}" if "generated_radius_of_gyration" in w else "–"
                e = f"{w['generated_bending_energy'][0]:.3g}" if "generated_bending_energy" in w else "–"
                ratio = f"{np.nanmean(g['cv'][0]) / laid_cv:.2f}"
                extra = f"{w['sde_potential_length'][0] * 1e3:.2f}, {w['sde_noise'][0]:.2f}" if name == "lay_down_sde" else ""
            if name == "laid":
                w = current(f, f"segments_{tag}")
                s = f"{w['input_radius_of_gyration'][0] * 1e3:.2f}"
                e = f"{w['input_bending_energy'][0]:.3g}"
            head = f"| {amps[p] * 1e3:g} | {c[p]:g} |" if first else "| | |"
            first = False
            print(f"{head} {name} | {s} | {e} | " + " | ".join(row[:2]) + f" | {ratio} | " + " | ".join(row[2:]) + f" | {extra} |")


def table4_table():
    f = h5py.File(TABLE4, "r")
    laid, g = current(f, "laid"), current(f, "grid")
    c = laid["belt_speed_ratio"][...]
    ref = g["reference_cv_corr"][...]
    print("| c | n_w | Δw (mm) | expected ρ (g/m²) | ρ_av (g/m²) | CV (%) | n_f 1 mm | measured CV_corr (%) | valid fibres |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for p in range(len(c)):
        row, _ = grid_row(g, p)
        n_w = int((laid["fibre_node_start"][p, 0] >= 0).sum())
        dw = laid["cd_period"][p] / n_w
        print(f"| {c[p]:g} | {n_w} | {dw * 1e3:.4f} | {g['expected_interior_density'][p]:.2f} | {row[0]} | {row[1]} | {row[2]} | {ref[p]:g} | {int(laid['valid_fibres'][p].sum())} |")
    # Like for like: surrogates from the same laid fibres on the same window (if run).
    surrogates = [s for s in ("random_phase_grid", "laid_segments_grid") if s in f]
    if not surrogates:
        return
    print()
    print("| c | laid web: ρ_av (g/m²), CV (%) | " + " | ".join(f"{s[:-5]}: ρ_av (g/m²), CV (%)" for s in surrogates) + " | measured CV_corr (%) |")
    print("|---:|---|" + "---|" * len(surrogates) + "---:|")
    for p in range(len(c)):
        row, _ = grid_row(g, p)
        cells = []
        for s in surrogates:
            r, _ = grid_row(current(f, s), p)
            cells.append(f"{r[0]}, {r[1]}")
        print(f"| {c[p]:g} | {row[0]}, {row[1]} | " + " | ".join(cells) + f" | {ref[p]:g} |")


def figure():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = h5py.File(STUDY, "r")
    laid = current(f, "laid")
    amps = swept(laid, "oscillation_amplitude")
    c = laid["belt_speed_ratio"][...]
    points = [p for p in range(len(c)) if abs(c[p] - 0.05) < 1e-9 and amps[p] in (0.001, 0.05)]
    fig, axes = plt.subplots(2, len(points), figsize=(7.0, 6.0), constrained_layout=True)
    for col, p in enumerate(points):
        pos, start, count = laid["laid_positions"][p, 0], laid["fibre_node_start"][p, 0], laid["fibre_laid_nodes"][p, 0]
        ax = axes[0, col]
        hl = len(start) // 2
        for j in range(len(start)):
            a, n = start[j], count[j]
            if a < 0:
                continue
            xy = pos[a:a + n, :2] * 1e3
            ax.plot(xy[:, 0], xy[:, 1], lw=0.3 if j != hl else 1.0, color="0.7" if j != hl else "C3")
        ax.set_title(f"laid by the physics, u0 = {amps[p] * 1e3:g} mm", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlabel("MD on the belt (mm)", fontsize=8)
        ax.set_ylabel("CD (mm)", fontsize=8)
        tag = f"u{int(round(amps[p] * 1000))}_c{int(round(c[p] * 100)):03d}"
        web = current(f, f"surrogate_{tag}")
        fp = web["fibre_positions"][0, 0]  # (sample_fibre, node, xy)
        ax = axes[1, col]
        for j in range(fp.shape[0]):
            xy = fp[j] * 1e3
            ok = np.isfinite(xy[:, 0])
            ax.plot(xy[ok, 0], xy[ok, 1] - 0.0, lw=0.3 if j != hl else 1.0, color="0.7" if j != hl else "C0")
        ax.set_xlim(axes[0, col].get_xlim())
        ax.set_title(f"random-phase surrogate of the same fibres", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlabel("MD (mm)", fontsize=8)
        ax.set_ylabel("CD (mm)", fontsize=8)
    os.makedirs(FIGURES, exist_ok=True)
    out = os.path.join(FIGURES, "laid_vs_surrogate_u0.png")
    fig.savefig(out, dpi=200)
    print(f"\nfigure: {out}")


def drivers_rows(f, laid_stage, grid_stage, note=""):
    """Rows of uniformity_drivers.yaml's table: each point's change from the base (the
    first stage's point 0)."""
    laid, g = current(f, laid_stage), current(f, grid_stage)
    base = current(f, "laid")
    names = ["air_speed", "friction_coefficient", "oscillation_frequency", "fibre_speed"]
    for p in range(laid["valid"].shape[0]):
        # a parameter the stage does not sweep is stored only where it is swept: the base's then
        value = lambda n: swept(laid, n)[p] if (n in laid or f"sweep_{n}" in laid) else swept(base, n)[0]
        changed = [f"{n} {value(n):g}" for n in names if value(n) != swept(base, n)[0]]
        valid = laid["valid"][p].astype(bool)
        row, zones = grid_row(g, p)
        s_laid = laid["radius_of_gyration_belt_removed"][p][valid]
        e_laid = laid["bending_energy"][p][valid]
        cpu = np.nansum(laid["wall_seconds"][p], axis=-1)
        # ΔCV against the stage's own base (point 0), with the standard error of the
        # difference of two means over realisations
        cv, cv0 = (np.asarray(g["cv"][q], dtype=float) * 100.0 for q in (p, 0))
        cv, cv0 = cv[np.isfinite(cv)], cv0[np.isfinite(cv0)]
        se = np.sqrt(cv.var(ddof=1) / cv.size + cv0.var(ddof=1) / cv0.size)
        delta = "" if p == 0 else f"{cv.mean() - cv0.mean():+.1f} ± {se:.1f}"
        print(f"| {', '.join(changed) or 'base'}{note} | {valid.sum()} of {valid.size} | {ms(s_laid, 1e3)} | {ms(e_laid, 1, 0)} | "
              + " | ".join(row[:2]) + f" | {delta} | " + " | ".join(row[2:]) + f" | {ms(cpu, 1, 0)} |")
    return zones


def drivers_table():
    """uniformity_drivers.yaml: each point against the base (point 0), one parameter changed."""
    f = h5py.File(DRIVERS, "r")
    print("| change from the base | valid fibres | S belt removed (mm) | e | ρ_av (g/m²) | CV (%) | ΔCV (points) | n_f 1 mm | n_f 11 mm | CPU per web (s) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    zones = drivers_rows(f, "laid", "grid")
    if "laid_implicit_axial" in f:
        drivers_rows(f, "laid_implicit_axial", "grid_implicit_axial", " (implicit_axial)")
    print(f"\nzone sizes used: {zones[0] * 1e3:g} mm and {zones[1] * 1e3:g} mm; interior density expected: "
          + ", ".join(f"{v:.2f}" for v in current(f, "grid")["expected_interior_density"][...]) + " g/m²")


if __name__ == "__main__":
    if "--drivers" in sys.argv:
        drivers_table()
        sys.exit(0)
    if os.path.exists(STUDY):
        study_table()
        print()
        generators_table()
    if os.path.exists(TABLE4):
        print()
        table4_table()
    if "--figure" in sys.argv:
        figure()
