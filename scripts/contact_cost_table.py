#!/usr/bin/env python3
"""The table of pipelines/studies/PHYSICAL_WEBS.md on what fibre contact costs and changes,
read from the archive of pipelines/studies/contact_cost.yaml: per web, with and without
`fibre_contact`, the wall time (and the contact broad phase's share), the laid nodes, the
highest laid node, and the laid segment pairs of different fibres closer than d/2 (crossed)
or 0.95 d, measured from the stored polylines.

Usage (from the repository root, after `laydown run pipelines/studies/contact_cost.yaml`):
    .venv/bin/python scripts/contact_cost_table.py [archive]   (default results/contact_cost.h5)
Needs h5py, numpy and pyyaml (tests/python/requirements.txt).
"""
import sys

import h5py
import numpy as np
import yaml

from physical_webs_table import current

ARCHIVE = "results/contact_cost.h5"


def segment_distances(p0, p1, q0, q1):
    """Least distance between every segment p0-p1 (n×3) and every q0-q1 (m×3): n×m."""
    d1 = (p1 - p0)[:, None, :]
    d2 = (q1 - q0)[None, :, :]
    r = p0[:, None, :] - q0[None, :, :]
    a = (d1 * d1).sum(-1)
    e = (d2 * d2).sum(-1)
    f = (d2 * r).sum(-1)
    c = (d1 * r).sum(-1)
    b = (d1 * d2).sum(-1)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > 1e-30, np.clip((b * f - c * e) / denom, 0, 1), 0.0)
        t = np.where(e > 0, (b * s + f) / e, 0.0)
        # t outside [0, 1]: clamp it and recompute s
        t_c = np.clip(t, 0, 1)
        s = np.where(t != t_c, np.clip(np.where(a > 0, (b * t_c - c) / a, 0.0), 0, 1), s)
    t = t_c
    gap = (p0[:, None, :] + s[..., None] * d1) - (q0[None, :, :] + t[..., None] * d2)
    return np.sqrt((gap * gap).sum(-1))


def laid_pairs(g, point, d, period):
    """Crossed (< d/2) and close (< 0.95 d) laid segment pairs of different fibres, and
    the least distance (in d), over the nearest CD image. Only single elements count: a
    polyline segment longer than 1.5 Δs joins two laid nodes across nodes not laid (lying
    on fibre above `bounce_tolerance`), and is not fibre."""
    pos = g["laid_positions"][point, 0]
    start = g["fibre_node_start"][point, 0]
    count = g["fibre_laid_nodes"][point, 0]
    ds = g["element_length"][point]
    segs = []
    for s0, n in zip(start, count):
        if s0 < 0 or n < 2:
            segs.append(None)
            continue
        x = pos[s0 : s0 + n]
        single = np.linalg.norm(x[1:] - x[:-1], axis=1) <= 1.5 * ds
        segs.append((x[:-1][single], x[1:][single]))
    crossed = close = 0
    least = np.inf
    for i in range(len(segs)):
        for j in range(i + 1, len(segs)):
            if segs[i] is None or segs[j] is None:
                continue
            (p0, p1), (q0, q1) = segs[i], segs[j]
            shift = period * np.round((p0[:, None, 1] - q0[None, :, 1]) / period)
            dist = np.full(shift.shape, np.inf)
            for k in np.unique(shift):
                m = shift == k
                off = np.array([0.0, k, 0.0])
                dk = segment_distances(p0, p1, q0 + off, q1 + off)
                dist[m] = dk[m]
            crossed += int((dist < 0.5 * d).sum())
            close += int(((dist >= 0.5 * d) & (dist < 0.95 * d)).sum())
            least = min(least, dist.min() / d)
    return crossed, close, least


def main():
    f = h5py.File(sys.argv[1] if len(sys.argv) > 1 else ARCHIVE, "r")
    print("| web | Δw | contact | wall | of it broad phase | laid nodes | highest laid node | valid fibres | laid pairs crossed / closer than 0.95 d | least distance |")
    print("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for base in ["table1", "table4"]:
        for stage in [base, base + "_contact"]:
            if stage not in f:
                continue
            g = current(f, stage)
            spacing = g["cd_period"][()] / (g["fibre_node_start"].shape[-1])
            d = float(yaml.safe_load(g.attrs["params_yaml"])["diameter"])
            for p in range(g["cd_period"].shape[0]):
                crossed, close, least = laid_pairs(g, p, d, g["cd_period"][p])
                lift = np.nanmax(g["laid_positions"][p, 0, :, 2])
                print(
                    f"| {base} | {1e3 * spacing[p]:.2f} mm | {'on' if stage.endswith('contact') else 'off'} "
                    f"| {g['wall_seconds_web'][p, 0]:.1f} s | {g['wall_seconds_contact'][p, 0]:.1f} s "
                    f"| {int(g['fibre_laid_nodes'][p, 0].sum())} | {1e3 * lift:.2f} mm "
                    f"| {int(g['valid_fibres'][p, 0])} / {g['valid'].shape[-1]} | {crossed} / {close} | {least:.3f} d |"
                )

    if "interval" in f:
        g = current(f, "interval")
        d = float(yaml.safe_load(g.attrs["params_yaml"])["diameter"])
        intervals = yaml.safe_load(g.attrs["sweep_yaml"])["contact_interval"]
        print()
        print("| contact_interval | wall | of it broad phase | candidate pairs per search | valid fibres | laid pairs crossed / closer than 0.95 d | least distance |")
        print("|---:|---:|---:|---:|---:|---:|---:|")
        for p in range(g["cd_period"].shape[0]):
            crossed, close, least = laid_pairs(g, p, d, g["cd_period"][p])
            interval = float(intervals[p])
            print(
                f"| {1e3 * interval:.2f} ms | {g['wall_seconds_web'][p, 0]:.1f} s | {g['wall_seconds_contact'][p, 0]:.1f} s "
                f"| {g['contact_candidate_pairs'][p, 0]:.0f} | {int(g['valid_fibres'][p, 0])} / {g['valid'].shape[-1]} | {crossed} / {close} | {least:.3f} d |"
            )


if __name__ == "__main__":
    sys.exit(main())
