#!/usr/bin/env bash
# Installs the Debian 12 packages graphslam builds and tests with. Run as root.
# Idempotent: packages already present are left alone.
set -euo pipefail
packages=(
  build-essential cmake
  libeigen3-dev libsuitesparse-dev libtbb-dev
  libspdlog-dev libfmt-dev libcli11-dev nlohmann-json3-dev libyaml-cpp-dev libzstd-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  liboctomap-dev libpcl-dev libgeographiclib-dev libplplot-dev plplot-driver-cairo pkg-config
  clang libclang-rt-14-dev
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
