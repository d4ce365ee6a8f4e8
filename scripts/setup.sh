#!/usr/bin/env bash
# Installs what dentsim needs on Debian 12 (skipping what is present) and builds the Rust
# workspace and the ParaView plugin. Sourced by demo.sh and test.sh; safe to run again.
set -euo pipefail

DENTSIM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export DENTSIM_ROOT
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$DENTSIM_ROOT/target}"
DENTSIM_PLUGIN_BUILD="$DENTSIM_ROOT/build/plugin"
DENTSIM_PLUGIN="$DENTSIM_PLUGIN_BUILD/lib/paraview-5.11/plugins/DentSim/DentSim.so"
export DENTSIM_PLUGIN_BUILD DENTSIM_PLUGIN

# REFERENCE.md "Building on Debian 12": OpenVDB 10 (+ Boost headers, TBB, Imath), ParaView 5.11
# with its Python modules and dev files, Xvfb for rendering, and the small real test files that
# pydicom and nibabel ship; DejaVu Sans for the text in dentsim assess's report picture; mpiexec
# for the plugin's MPI test; Qt's help tools for the plugin's help pages (from its XML docs).
DENTSIM_APT_PACKAGES=(
  build-essential pkg-config cmake git ca-certificates curl
  libopenvdb-dev libboost-dev libtbb-dev libimath-dev libopenvdb-tools python3-openvdb
  paraview paraview-dev python3-paraview libopenmpi-dev libdouble-conversion-dev
  xvfb xauth fonts-dejavu-core
  openmpi-bin qhelpgenerator-qt5 qtxmlpatterns5-dev-tools qttools5-dev
  python3-numpy python3-pydicom python3-nibabel
  libhidapi-dev libopenigtlink-dev openigtlink-examples python3-pip
)

# PyPI packages for /usr/bin/python3 (Debian ships none of them): pyigtl is the OpenIGTLink peer
# the device tests and `dentsim bench`'s igtl_round_trip measure against.
DENTSIM_PIP_PACKAGES=(pyigtl)

# Seconds since the script started, so a slow run's log shows which step took the time.
dentsim_log() { printf '[dentsim setup %4ds] %s\n' "$SECONDS" "$*" >&2; }

dentsim_install_packages() {
  local missing=()
  for p in "${DENTSIM_APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if ((${#missing[@]})); then
    dentsim_log "installing Debian packages: ${missing[*]}"
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  fi
}

dentsim_install_pip_packages() {
  local missing=()
  for p in "${DENTSIM_PIP_PACKAGES[@]}"; do
    /usr/bin/python3 -c "import $p" 2>/dev/null || missing+=("$p")
  done
  if ((${#missing[@]})); then
    dentsim_log "installing PyPI packages for /usr/bin/python3: ${missing[*]}"
    /usr/bin/python3 -m pip install -q --break-system-packages "${missing[@]}" >/dev/null
  fi
}

dentsim_ensure_cargo() {
  export PATH="$HOME/.cargo/bin:$PATH"
  if ! command -v cargo >/dev/null 2>&1; then
    dentsim_log "no Rust toolchain found; installing Debian's cargo (dentsim needs Rust >= 1.88)"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends cargo rustc >/dev/null
  fi
}

dentsim_build() {
  dentsim_log "building the Rust workspace (release)"
  (cd "$DENTSIM_ROOT" && cargo build --release --workspace --quiet)
  dentsim_log "building the ParaView plugin"
  cmake -S "$DENTSIM_ROOT/plugin" -B "$DENTSIM_PLUGIN_BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$DENTSIM_PLUGIN_BUILD" -j "$(nproc)" >/dev/null
}

dentsim_install_packages
dentsim_install_pip_packages
dentsim_ensure_cargo
dentsim_build
dentsim_log "set up"

