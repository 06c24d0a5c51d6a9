#!/usr/bin/env bash
# Installs the Debian packages QuadHand builds and tests with, as listed in
# scripts/debian-packages.txt (the one list; tests/setup checks it against the
# CMake files). Idempotent: when everything is already installed it does
# nothing (and needs no root) beyond `npm ci` for libs/viz/web and
# tests/link/peer if their node_modules are missing.
# Usage: bash scripts/setup.sh
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
package_list="$here/debian-packages.txt"

# The one list (scripts/debian-packages.txt): the first word of each line is a
# package; `when-missing:CMD` makes it conditional on CMD not being on the PATH.
packages=()
while read -r package rest; do
  case "$package" in ''|'#'*) continue ;; esac
  rest="${rest%%#*}"
  skip=0
  for word in $rest; do
    case "$word" in
      when-missing:*) command -v "${word#when-missing:}" >/dev/null 2>&1 && skip=1 ;;
    esac
  done
  [ "$skip" -eq 1 ] || packages+=("$package")
done < "$package_list"

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done

# three.js as pinned in libs/viz/web/package-lock.json (CMake runs the same
# `npm ci` when node_modules is missing; the built pages never fetch it).
install_viz_web() {
  local web
  web="$here/../libs/viz/web"
  if [ ! -f "$web/node_modules/three/package.json" ]; then
    echo "setup: npm ci in $web"
    (cd "$web" && npm ci --no-audit --no-fund)
  fi
}

# node-mavlink as pinned in tests/link/peer/package-lock.json: the independent
# MAVLink peer the link tests talk to (tests/link/peer_test.cc fails without it).
install_link_peer() {
  local peer
  peer="$here/../tests/link/peer"
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
