#!/usr/bin/env bash
# The README's test command: install dependencies, build (Release, warnings
# on), run the whole test suite with CTest. Exits non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/../.."
bash tools/setup/install_dependencies.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2
cd build
ctest --output-on-failure -j2 --timeout 1500
