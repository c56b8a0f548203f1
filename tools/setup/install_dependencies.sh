#!/usr/bin/env bash
# Installs the Debian 12 packages graphslam builds and tests with. Run as root.
# Idempotent: packages already present are left alone.
set -euo pipefail
packages=(
  build-essential cmake
  libeigen3-dev libsuitesparse-dev libtbb-dev
  libboost-dev libspdlog-dev libfmt-dev libcli11-dev nlohmann-json3-dev libyaml-cpp-dev libzstd-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  liboctomap-dev libpcl-dev libgeographiclib-dev libplplot-dev plplot-driver-cairo pkg-config
  clang libclang-rt-14-dev
  libopenmpi-dev openmpi-bin libpetsc-real-dev
  libopenblas0-serial
  # tools/report_screenshots.sh and its test: headless Chromium (about 110 MB
  # of packages, under a minute of apt time) and libpng to read the PNGs.
  chromium fonts-dejavu-core libpng-dev
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

# CHOLMOD's supernodal factorization runs on the libblas.so.3 / liblapack.so.3
# alternatives: OpenBLAS, single-threaded (our threads are TBB's; a threaded
# BLAS under them oversubscribes the cores), not the reference BLAS, which
# took 3x the CPU time on sphere2500 (docs/history/benchmarks-notebook-2026-11.md,
# "Everyday pose graphs: initialization and BLAS").
select_openblas() {
  local dir=/usr/lib/x86_64-linux-gnu/openblas-serial
  update-alternatives --set libblas.so.3-x86_64-linux-gnu "$dir/libblas.so.3"
  update-alternatives --set liblapack.so.3-x86_64-linux-gnu "$dir/liblapack.so.3"
}
select_openblas

# Optional, perf-only: Ceres Solver for the peer harness perf/ceres_peer
# (docs/peers.md). Opt-in (GRAPHSLAM_WITH_CERES=1) because building the peer
# adds minutes to the default build. libceres-dev pulls in ATLAS and makes it
# the libblas.so.3 / liblapack.so.3 alternative, which changes CHOLMOD's
# timings; OpenBLAS (above) is set back.
if [[ "${GRAPHSLAM_WITH_CERES:-0}" == 1 ]]; then
  if ! dpkg-query -W -f='${Status}' libceres-dev 2>/dev/null | grep -q "install ok installed"; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends libceres-dev
  fi
  select_openblas
fi
