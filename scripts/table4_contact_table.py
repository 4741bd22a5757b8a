#!/usr/bin/env python3
"""The tables of pipelines/studies/PHYSICAL_WEBS.md, "With fibre contact, at c = 0.05 on a
small window", read from the archive of pipelines/studies/table4_contact.yaml: per web, with
and without `fibre_contact`, the valid fibres, ρ_av, CV and formation number of the 1 mm
cells, S belt removed, the height of the laid nodes in the interior, the laid segment pairs
of different fibres closer than d/2 (crossed) or 0.95 d, and what the web cost.

Usage (from the repository root, after `laydown run pipelines/studies/table4_contact.yaml`):
    .venv/bin/python scripts/table4_contact_table.py [archive ...]   (default results/table4_contact.h5)
Several archives may be named (e.g. the two pairs run into separate archives); each stage
is read from the first archive that has it. Needs h5py, numpy and pyyaml
(tests/python/requirements.txt).
"""
import sys

import h5py
import numpy as np
import yaml

from contact_cost_table import laid_pairs
from physical_webs_table import current

ARCHIVE = "results/table4_contact.h5"
# (laid stage, grid stage) of each web, as table4_contact.yaml names them
WEBS = [
    ("c = 0.05", "laid", "grid"),
    ("c = 0.05", "laid_contact", "grid_contact"),
    ("c = 0.07", "laid_c007", "grid_c007"),
    ("c = 0.07", "laid_contact_c007", "grid_contact_c007"),
]


def row(condition, laid, grid):
    """One table row of laid web `laid` (one point, one replicate) and its grid `grid`."""
    d = float(yaml.safe_load(laid.attrs["params_yaml"])["diameter"])
    contact = bool(yaml.safe_load(laid.attrs["params_yaml"]).get("fibre_contact", False))
    zones = grid["zone_size"][...]
    nf = grid["formation_number"][0, 0]
    nf_at = " / ".join(f"{nf[int(np.argmin(np.abs(zones - z)))]:.2f}" for z in (1e-3, 2e-3, 4e-3))
    pos = laid["laid_positions"][0, 0]
    x_min, x_max = laid["interior_md_min"][0, 0], laid["interior_md_max"][0, 0]
    inside = (pos[:, 0] >= x_min) & (pos[:, 0] <= x_max)
    z = pos[inside, 2] / d
    crossed, close, least = laid_pairs(laid, 0, d, laid["cd_period"][0])
    valid = int(laid["valid_fibres"][0, 0])
    rollbacks = int(np.nansum(laid["rollbacks"][0, 0]))
    node_steps = float(np.nansum(laid["node_steps"][0, 0]))
    steps = laid["steps"][0, 0]
    lock = laid["contact_lock_steps"][0, 0] if contact else np.nan
    return (
        f"| {condition} | {'with' if contact else 'without'} contact | {valid} of {laid['valid'].shape[-1]}, {rollbacks} rollbacks "
        f"| {grid['mean_areal_density'][0, 0]:.2f} | {100 * grid['cv'][0, 0]:.1f} | {nf_at} "
        f"| {1e3 * np.nanmean(laid['radius_of_gyration_belt_removed'][0, 0]):.2f} "
        f"| {np.median(z):.1f} / {np.percentile(z, 90):.1f} / {z.max():.1f} d "
        f"| {crossed} / {close}, least {least:.3f} d "
        f"| {node_steps:.2e} | {f'{lock:.0f} lock' if contact else f'{np.min(steps):.0f}-{np.max(steps):.0f} per fibre'} "
        f"| {laid['wall_seconds_web'][0, 0]:.0f} s ({laid.attrs['cpu_seconds']:.0f} s CPU) |"
    ), f"{100 * grid['random_line_cv'][0, 0, int(np.argmin(np.abs(zones - 1e-3)))]:.1f}"


def main():
    files = [h5py.File(path, "r") for path in (sys.argv[1:] or [ARCHIVE])]

    def stage(name):
        for f in files:
            if name in f:
                return current(f, name)
        return None

    print("| condition | web | valid fibres | ρ_av (g/m²) | CV 1 mm (%) | n_f 1 / 2 / 4 mm | S belt removed (mm) | laid node height in the interior: median / 90 % / max | laid pairs crossed / closer than 0.95 d | node-steps | steps | wall (CPU) |")
    print("|---|---|---|---:|---:|---|---:|---|---|---:|---:|---:|")
    random_line = []
    for condition, laid_name, grid_name in WEBS:
        laid, grid = stage(laid_name), stage(grid_name)
        if laid is None or grid is None:
            continue
        text, rl = row(condition, laid, grid)
        print(text)
        random_line.append(f"{grid_name} {rl} %")
    print()
    print("random-line CV of the 1 mm cells: " + ", ".join(random_line))


if __name__ == "__main__":
    sys.exit(main())
