#!/usr/bin/env bash
# The README's main job: install dependencies, build, then one complete batch
# run on the embedded default dataset — a simulated campus (two runs, GPS on
# part of the poses) generated on the fly with ground truth — writing the
# optimized graph, trajectory, features, run report and an evaluation against
# ground truth into out/ (OUT=... to change). Exit code: that of the solve.
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-out}
bash tools/setup/install_dependencies.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2
mkdir -p "$OUT"
graphslam=build/bin/graphslam
"$graphslam" simulate -o "$OUT/dataset" --poses 3000 --runs 2 --gps-every 25 --seed 1
"$graphslam" solve "$OUT/dataset/log.graphslam" \
  -o "$OUT/graph.g2o" --tum "$OUT/trajectory.tum" --features-csv "$OUT/features.csv" \
  --report "$OUT/report.json"
"$graphslam" evaluate --trajectory "$OUT/trajectory.tum" \
  --ground-truth "$OUT/dataset/ground_truth.tum" \
  --features "$OUT/features.csv" --ground-truth-features "$OUT/dataset/ground_truth_features.csv" \
  --report "$OUT/evaluation.json"
echo "main job done: outputs in $OUT/ (graph.g2o, trajectory.tum, features.csv, report.json, evaluation.json)"
