#!/usr/bin/env bash
# Installs the system packages laydown builds against (Debian/Ubuntu): HDF5 1.10+
# with its high-level library (dimension scales), pkg-config, and a TrueType font for
# the labels of `laydown plot` (DejaVu). Uses sudo when not root.
set -euo pipefail
need=()
for pkg in libhdf5-dev pkg-config fonts-dejavu-core; do
  dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done
if [ ${#need[@]} -eq 0 ]; then
  exit 0
fi
if ! command -v apt-get >/dev/null 2>&1; then
  echo "laydown needs: ${need[*]} (HDF5 development files and pkg-config); install them with your package manager" >&2
  exit 1
fi
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
echo "installing ${need[*]} ..." >&2
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
