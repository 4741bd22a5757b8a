#!/usr/bin/env bash
# The whole test suite: Rust unit, integration and doc tests (release build: the
# physics tests are heavy), the Slurm executor on a real one-node cluster, then the Python cross-checks of the archive with h5py,
# xarray (h5netcdf), numpy and jsonschema, in a local virtualenv (.venv).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cargo build --release --quiet
cargo test --release
# The Slurm executor against a real one-node Slurm cluster (installs Debian's Slurm and
# munge when root; prints `SKIPPED: slurm: <reason>` where that is impossible).
cargo test --release --test slurm -- --ignored --nocapture
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/python/requirements.txt
LAYDOWN_BIN="$(pwd)/target/release/laydown" .venv/bin/python -m pytest -q tests/python
