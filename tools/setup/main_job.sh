#!/usr/bin/env bash
# The README's main job: install dependencies, build, then one complete batch
# job (`graphslam run`, docs/jobs.md) on the embedded default job file
# tools/setup/default_job.yaml — a simulated campus driven three times, GPS
# only outdoors (an indoor region without reception), solved with and without
# GPS for the indoor-error comparison — writing into out/ (OUT=... to change):
#   trajectories/<run>.tum, features.csv, graph.g2o, report.json, report.html,
#   log.jsonl, map.bt and map.pcd (the 3-D map from the simulated scans).
# RESUME=1 continues an interrupted job. Exit code: that of `graphslam run`.
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-out}
bash tools/setup/install_dependencies.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2 --target graphslam
resume=()
if [[ "${RESUME:-0}" == 1 ]]; then resume=(--resume); fi
build/bin/graphslam run tools/setup/default_job.yaml -o "$OUT" "${resume[@]}"
echo "main job done: outputs in $OUT/ (trajectories/, features.csv, graph.g2o, map.bt, map.pcd, report.json, report.html, log.jsonl)"
