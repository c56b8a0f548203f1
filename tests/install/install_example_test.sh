#!/bin/bash
# The installed package works for a consumer (docs/library.md):
#   cmake --install BUILD --prefix P
#   cmake -S docs/example -B ex -DCMAKE_PREFIX_PATH=P && cmake --build ex
# then the example solves DATASET to the chi2 of `graphslam solve
# --initialization progressive` (the steps the example spells out) and
# writes the same graph.
# usage: install_example_test.sh BUILD_DIR SOURCE_DIR DATASET
set -euo pipefail
build=$1 source=$2 dataset=$3
if [[ ! -e $dataset ]]; then
  echo "dataset missing: $dataset"
  [[ ${CI:-} == true ]] && exit 1
  exit 77  # SKIP_RETURN_CODE
fi
work=$(mktemp -d "${TMPDIR:-/tmp}/graphslam_install.XXXXXX")
trap 'rm -rf "$work"' EXIT

cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
for file in lib/cmake/graphslam/graphslamConfig.cmake \
            lib/cmake/graphslam/graphslamConfigVersion.cmake \
            include/graphslam/core/graphslam_solver.h include/graphslam/storage/g2o_reader.h \
            lib/libgraphslam_core.a lib/libgraphslam_storage.a lib/libgraphslam_partition.a; do
  [[ -f $work/prefix/$file ]] || { echo "not installed: $file"; exit 1; }
done
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S "$source/docs/example" -B "$work/ex" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" >"$work/configure.log" ||
  { cat "$work/configure.log"; exit 1; }
cmake --build "$work/ex" -j2 >"$work/build.log" || { cat "$work/build.log"; exit 1; }

"$work/ex/graphslam_example" "$dataset" "$work/example.g2o" >"$work/example.txt"
"$build/bin/graphslam" solve "$dataset" --initialization progressive -o "$work/solve.g2o" \
  --report "$work/solve.json" -q
example=$(awk '$1 == "final" && $2 == "chi2" {print $3}' "$work/example.txt")
solve=$(grep -o '"final_chi2": *[-0-9.eE+]*' "$work/solve.json" | sed 's/.*: *//')
echo "final chi2: example $example, graphslam solve $solve"
awk -v a="$example" -v b="$solve" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(a > 0 && d <= 1e-9 * b) }' ||
  { echo "chi2 differs"; exit 1; }
cmp "$work/example.g2o" "$work/solve.g2o" || { echo "the written graphs differ"; exit 1; }
echo "same chi2 and the same graph"
