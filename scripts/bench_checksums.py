"""What verifying a stored dataset costs: HDF5's Fletcher32 per-chunk checksums against
hashing the values with BLAKE3 (what `laydown verify` and every input read do), on
160 MB of deflate-compressed float64 chunked like the archive's (64k elements).

Run: .venv/bin/pip install blake3 && .venv/bin/python scripts/bench_checksums.py
"""
import tempfile
import time
from pathlib import Path

import blake3
import h5py
import numpy as np

n = 20_000_000
values = np.cumsum(np.random.default_rng(1).standard_normal(n)) * 1e-3
tmp = Path(tempfile.mkdtemp())
for name, extra in [("deflate", {}), ("deflate+fletcher32", {"fletcher32": True})]:
    with h5py.File(tmp / f"{name}.h5", "w") as f:
        f.create_dataset("x", data=values, chunks=(65536,), compression="gzip", compression_opts=4, **extra)
times = {}
for _ in range(5):
    for name in ["deflate", "deflate+fletcher32"]:
        t = time.perf_counter()
        with h5py.File(tmp / f"{name}.h5", "r") as f:
            x = f["x"][:]
        times.setdefault(f"read {name}", []).append(time.perf_counter() - t)
    t = time.perf_counter()
    blake3.blake3(x.tobytes()).hexdigest()
    times.setdefault("blake3 of the values", []).append(time.perf_counter() - t)
for k, v in times.items():
    v.sort()
    print(f"{k:28s} min {v[0]:.3f} s  median {v[2]:.3f} s  ({values.nbytes / v[0] / 1e6:.0f} MB/s)")
