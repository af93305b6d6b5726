#!/usr/bin/env bash
# Installs the Debian packages ProbeStudio needs, only those missing; quiet when all are there.
# Sourced by scripts/run and scripts/test (ps_install_deps) and by scripts/compare-placement,
# which alone needs PS_PLOT_DEPS and installs them on demand.

# Plotting for scripts/compare-placement only (its PNGs); not installed by run/test, so building
# and testing pull no plotting packages.
PS_PLOT_DEPS=(gnuplot-nox)

# Installs those of the given packages that are missing (with sudo when not root).
ps_install_packages() {
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "Installing missing packages: ${missing[*]}"
  local sudo=()
  [ "$(id -u)" -ne 0 ] && sudo=(sudo)
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
}

ps_install_deps() {
  local pkgs=(
    cmake ninja-build g++ pkg-config python3
    libembree-dev libtinygltf-dev libopenimageio-dev openimageio-tools libtbb-dev libglm-dev
    nlohmann-json3-dev libcli11-dev libcgal-dev libgmp-dev libmpfr-dev
    libgtest-dev libgmock-dev libbenchmark-dev
    qt6-base-dev libqt6opengl6-dev qt6-charts-dev qt6-qpa-plugins
    xvfb xauth libgl1-mesa-dri libglx-mesa0
    clang libclang-rt-14-dev clang-format
  )
  ps_install_packages "${pkgs[@]}"
}
