#!/usr/bin/env bash
# From a fresh clone: install what is missing, build in release mode, run
# pipelines/quickstart.yaml end to end and say where the results are.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cargo build --release --quiet
./target/release/laydown run pipelines/quickstart.yaml
echo
./target/release/laydown ls results/quickstart.h5
echo
echo "figures:"
./target/release/laydown plot results/quickstart.h5
echo
echo "archive: $(pwd)/results/quickstart.h5"
echo "inspect: ./target/release/laydown show results/quickstart.h5 ideal"
echo "python:  t = xarray.open_datatree('results/quickstart.h5', engine='h5netcdf'); t['ideal'][t['ideal'].attrs['current']]"
