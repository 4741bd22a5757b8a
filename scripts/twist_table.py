#!/usr/bin/env python3
"""Table of the twist study (pipelines/studies/twist.yaml): per stage, over its valid
replicates, S and e (mean ± std), the laid fibre's coiling and the cost.

Coiling, from the laid nodes in fibre order projected on the belt (x, y):
- turns = Σ φ_k / 2π, φ_k the signed turning angle between successive laid segments;
- regularity = |Σ φ_k| / Σ |φ_k|: 1 when the fibre always turns the same way (coils
  laid one on another), near 0 when it meanders (loops of both senses, alternating);
- coil radius = Σ |Δs_k| / Σ |φ_k|, the mean radius of curvature of the laid fibre.
Twist (`effects.twist`): |Ω| the twist rate of the hanging fibre at the end (rad/m) and
|laid twist| the twist laid down with the fibre (turns), means of the magnitudes.

Usage: scripts/twist_table.py results/twist.h5 [stage ...]
"""
import sys

import h5py
import numpy as np

from laid_curves import turning_angles
from physical_webs_table import current


def coiling(xy):
    """(turns, regularity, coil radius) of a laid polyline (n, 2), NaN rows dropped."""
    turn, length = turning_angles(xy)
    total = np.abs(turn).sum()
    return turn.sum() / (2 * np.pi), abs(turn.sum()) / total, length[1:].sum() / total


def main(path, stages):
    with h5py.File(path, "r") as f:
        names = stages or list(f.keys())
        print("| stage | valid | S (mm) | e | turns | regularity | coil radius (mm) | abs Ω end (rad/m) | abs laid twist (turns) | wall per replicate (s) | steps |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for name in names:
            g = current(f, name)
            valid = g["valid"][0].astype(bool)
            s = g["radius_of_gyration"][0][valid] * 1e3
            e = g["bending_energy"][0][valid]
            coils = np.array([coiling(g["laid_positions"][0, r, :, :2]) for r in np.flatnonzero(valid)])
            omega = np.abs(g["twist_rate"][0][valid])
            laid = np.abs(g["laid_twist"][0][valid]) / (2 * np.pi)
            wall = g["wall_seconds"][0]
            steps = g["steps"][0]
            ms = lambda a, fmt: f"{fmt.format(a.mean())} ± {fmt.format(a.std(ddof=1))}"
            print(
                f"| {name} | {valid.sum()}/{valid.size} | {ms(s, '{:.2f}')} | {ms(e, '{:.0f}')} | "
                f"{ms(np.abs(coils[:, 0]), '{:.1f}')} | {ms(coils[:, 1], '{:.2f}')} | {ms(coils[:, 2] * 1e3, '{:.2f}')} | "
                f"{ms(omega, '{:.0f}')} | {ms(laid, '{:.1f}')} | "
                f"{wall.mean():.2f} | {steps.mean():.0f} |"
            )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
