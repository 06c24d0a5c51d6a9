#!/usr/bin/env bash
# Installs the Debian packages QuadHand builds and tests with. Idempotent:
# when everything is already installed it does nothing (and needs no root)
# beyond `npm ci` for libs/viz/web and tests/link/peer if their node_modules are missing.
# Usage: bash scripts/setup.sh
set -euo pipefail

# Only what the code uses (docs/dependencies.md says which part uses what).
packages=(
  build-essential cmake pkg-config
  libeigen3-dev          # linear algebra everywhere
  libcgal-dev            # mesh IO, union, exact distances (libs/geometry)
  liburdfdom-dev         # URDF parsing (libs/robot)
  libcli11-dev           # command-line parsing (apps)
  libgtest-dev libgmock-dev  # unit tests
  libbenchmark-dev       # micro-benchmarks
  libyaml-cpp-dev        # YAML files (primitive lists, tasks)
  libpcl-dev             # PCD point clouds (libs/scene; only pcl_io and pcl_common are linked)
  liboctomap-dev libdynamicedt3d-dev  # ESDF baseline: occupancy octree and distance transform (libs/env)
  libceres-dev coinor-libipopt-dev libnlopt-cxx-dev  # optional solver back-ends (solvers/ceres, ipopt, nlopt)
  chromium               # headless browser that loads the HTML view in tests/viz
  python3-matplotlib     # plots of scripts/figure8.py (the simulator's figure-eight experiment)
  libssl-dev             # libcrypto's SHA-256 for MAVLink message signing (libs/link)
)

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
# Node.js and npm install the pinned three.js of the HTML view (libs/viz/web).
# Any npm will do: NodeSource's nodejs bundles one and conflicts with Debian's npm.
if ! command -v npm >/dev/null; then
  missing+=(nodejs npm)
fi

# three.js as pinned in libs/viz/web/package-lock.json (CMake runs the same
# `npm ci` when node_modules is missing; the built pages never fetch it).
install_viz_web() {
  local web
  web="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/libs/viz/web"
  if [ ! -f "$web/node_modules/three/package.json" ]; then
    echo "setup: npm ci in $web"
    (cd "$web" && npm ci --no-audit --no-fund)
  fi
}

# node-mavlink as pinned in tests/link/peer/package-lock.json: the independent
# MAVLink peer the link tests talk to (tests/link/peer_test.cc fails without it).
install_link_peer() {
  local peer
  peer="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/tests/link/peer"
  if [ ! -f "$peer/node_modules/node-mavlink/package.json" ]; then
    echo "setup: npm ci in $peer"
    (cd "$peer" && npm ci --no-audit --no-fund)
  fi
}

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all packages already installed"
  install_viz_web
  install_link_peer
  exit 0
fi

echo "setup: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root (or sudo) to install packages" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=900 update -qq
"${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=900 install -y -qq --no-install-recommends "${missing[@]}"
install_viz_web
install_link_peer
echo "setup: done"
