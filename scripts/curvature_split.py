#!/usr/bin/env python3
"""Where a laydown scheme's e differs from the explicit reference's: the curvature of the
laid fibres split into its net turning and its fluctuation (pipelines/studies/FIBRE_SPEED.md,
"At the same converged mesh").

e = (L/2) ∫κ² ds (eq 6), so at a given laid length e follows the mean of κ² along the fibre,
and ⟨κ²⟩ = ⟨κ⟩² + var κ with κ the signed curvature of the laid fibre in the belt plane.
⟨κ⟩ is the net turning per length: loops laid one way round keep it large, loops whose sense
alternates cancel it. ⟨|κ|⟩ is how tightly the fibre bends, whatever the sense.

For every laydown stage of the archive (its current version) and every sweep point, prints
the mean over valid replicates of S, e, L, ⟨κ²⟩, |⟨κ⟩|, var κ and ⟨|κ|⟩, each relative to the
reference stage's (laydown_reference unless named) at the sweep values the point shares
with one of its points (its first point when none), with the standard error of the
difference (replicates unpaired: the seeds do not correlate the runs of two schemes).

REFERENCE_STAGE may name several stages, comma-separated: their replicates are pooled point by
point (e.g. the explicit reference at two steps, or on two seeds). POOL, comma-separated
stages, adds one row per point label those stages share, their replicates pooled.

Usage (from the repository root, after `laydown run pipelines/studies/converged_mesh_accuracy.yaml`):
    .venv/bin/python scripts/curvature_split.py [ARCHIVE [REFERENCE_STAGE[,STAGE...] [POOL]]]
e.g. `... results/converged_mesh_accuracy.h5 laydown_reference,laydown_reference_half_step,laydown_reference_seed12 laydown_start,laydown_default_seed12`.
Needs h5py and numpy (tests/python/requirements.txt).
"""
import sys

import h5py
import numpy as np

from laid_curves import turning_angles
from physical_webs_table import current

ARCHIVE = "results/converged_mesh_accuracy.h5"
MEASURES = ["S", "e", "L", "<k^2>", "|<k>|", "var k", "<|k|>"]


def signed_curvature(laid):
    """Signed curvature (1/m) at the inner nodes of a laid polyline in the belt plane:
    turning angle over the mean length of the two segments, as geometry::bending_energy."""
    turn, length = turning_angles(laid[:, :2])
    return turn / (0.5 * (length[1:] + length[:-1]))


def point_measures(group, point):
    """The MEASURES of every valid replicate of one sweep point, (replicates, measures);
    each dataset read once."""
    valid = np.flatnonzero(group["valid"][point].astype(bool))
    laid = group["laid_positions"][point]
    per_replicate = [group[name][point][valid] for name in ("radius_of_gyration", "bending_energy", "laid_length")]
    curvature = []
    for r in valid:
        k = signed_curvature(laid[r])
        curvature.append([np.mean(k * k), abs(np.mean(k)), np.var(k), np.mean(np.abs(k))])
    return np.column_stack(per_replicate + [np.array(curvature).reshape(len(valid), 4)])


def label(group, point):
    """The sweep point's swept values, e.g. "start=fed, time_step_factor=0.4": the
    datasets of the point's length other than dimension scales and per-point summaries."""
    parts = []
    for name, data in group.items():
        if (not data.is_scale and data.shape == group["point"].shape and data.dtype.kind in "OSf"
                and not name.endswith(("_mean", "_std"))):
            v = data[point]
            parts.append(f"{name}={v.decode() if isinstance(v, bytes) else f'{v:g}'}")
    return ", ".join(parts) or "-"


def matching(point, references):
    """The reference point whose swept values the candidate point shares, the most specific
    one (e.g. "friction_coefficient=10" for "friction_coefficient=10, integrator=inextensible")."""
    items = set(point.split(", "))
    shared = [ref for ref in references if set(ref.split(", ")) <= items]
    return max(shared, key=len, default=None)


def difference(values, ref):
    """Relative difference of the means (%) and its standard error, unpaired."""
    ref_mean = ref.mean(axis=0)
    ref_se = ref.std(axis=0, ddof=1) / np.sqrt(len(ref))
    mean = values.mean(axis=0)
    se = values.std(axis=0, ddof=1) / np.sqrt(len(values))
    return 100 * (mean / ref_mean - 1), 100 * np.hypot(se / ref_mean, ref_se * mean / ref_mean**2)


def pooled(rows, stages, shared=False):
    """{point label: the replicates of `stages` at that label, stacked}, in first-seen order;
    with `shared`, only the labels every one of `stages` has."""
    out, having = {}, {}
    for stage, point, values in rows:
        if stage in stages:
            out[point] = np.vstack([out[point], values]) if point in out else values
            having.setdefault(point, set()).add(stage)
    return {point: v for point, v in out.items() if not shared or having[point] == set(stages)}


def table(path, reference, pool=()):
    reference = reference.split(",")
    with h5py.File(path, "r") as f:
        stages = [name for name in f if "bending_energy" in current(f, name)]
        missing = [name for name in reference + list(pool) if name not in stages]
        if missing:
            sys.exit(f"{path}: no laydown stage named {', '.join(missing)}; there are: {', '.join(stages)}")
        both = [name for name in pool if name in reference]
        if both:
            sys.exit(f"{', '.join(both)}: named as reference and in the pool; a stage is one or the other")
        stages.sort(key=lambda name: name not in reference)
        rows = []
        for stage in stages:
            g = current(f, stage)
            for p in range(g["valid"].shape[0]):
                rows.append((stage, label(g, p), point_measures(g, p)))
    references = pooled(rows, reference)
    name = " + ".join(reference)
    print("| stage | point | valid | " + " | ".join(MEASURES) + " |")
    print("|---|---|---:|" + "---:|" * len(MEASURES))
    for point, values in references.items():
        print(f"| {name} (reference) | {point} | {len(values)} | "
              + " | ".join(f"{m:.4g}" for m in values.mean(axis=0)) + " |")
    first = next(iter(references.values()))
    candidates = [row for row in rows if row[0] not in reference]
    if pool:
        candidates += [(" + ".join(pool) + " (pooled)", point, values) for point, values in pooled(rows, pool, shared=True).items()]
    for stage, point, values in candidates:
        rel, rel_se = difference(values, references.get(matching(point, references), first))
        print(f"| {stage} | {point} | {len(values)} | "
              + " | ".join(f"{r:+.1f} ± {s:.1f} %" for r, s in zip(rel, rel_se)) + " |")


if __name__ == "__main__":
    table(sys.argv[1] if len(sys.argv) > 1 else ARCHIVE, sys.argv[2] if len(sys.argv) > 2 else "laydown_reference",
          sys.argv[3].split(",") if len(sys.argv) > 3 else ())
