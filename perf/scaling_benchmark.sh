#!/usr/bin/env bash
# Scaling benchmark of the out-of-core path (issue 3, docs/out_of_core.md):
# for each size, simulate a campus, ingest it into a chunk store (bounded
# memory), solve the store, and record ingest seconds, seconds per
# Levenberg-Marquardt iteration, peak RSS of the ingest and of the solve
# (/usr/bin/time -v) and the store's bytes on disk. Writes
#   OUT/scaling.csv, OUT/scaling.md (Markdown table), OUT/scaling.png (PLplot)
#
# usage: perf/scaling_benchmark.sh BUILD_DIR OUT_DIR [FEATURES...]
#   default sizes: 10000 100000 1000000
# environment: POSES_PER_FEATURE (default 1), RUNS (2), ITERATIONS (1),
#   THREADS (2), CHUNK (4096), MEMORY_LIMIT (8G; the estimate needs 4 KiB per pose), SEED (1), SPEED (8 m/s),
#   SOLVER (cholmod), INGEST_MEMORY_LIMIT (unset: a buffer of 1 165 084
#   observations, what 256M gave when the limit sized only the buffer, so the
#   larger sizes spill to several buckets; set: the ingest's peak budget),
#   LANDMARK_SPACING ("MIN MAX", default: the simulator's) and SENSOR_RANGE (m)
#   for the issue's proportions (10^8 features / 10^6 poses / ~4-5*10^8
#   observations: POSES_PER_FEATURE=0.01 LANDMARK_SPACING="0.015 0.025"
#   SENSOR_RANGE=8), COMPRESS (1: simulate --compress, a zstd log; the ingest
#   reads it as is)
#
# Sizes: --features N landmarks, --poses N * POSES_PER_FEATURE (2 runs, GPS
# every 50 poses), driving SPEED m/s (8: 4 m between poses, so a pose sees new
# landmarks and about half of them are observed, ~7 observations each). The
# solve runs ITERATIONS iterations in streaming mode (--streaming-poses 0:
# observations stay on disk, Table 1 guess from the ingest: --initialization
# odometry, so the pose-graph initializer's time is not mixed in); seconds per
# iteration = optimize seconds / iterations (with 1 iteration this includes
# the initial chi2 pass and CHOLMOD's symbolic analysis).
# The simulator streams (--streaming: world per street segment).
set -euo pipefail
BUILD=${1:?usage: scaling_benchmark.sh BUILD_DIR OUT_DIR [FEATURES...]}
OUT=${2:?usage: scaling_benchmark.sh BUILD_DIR OUT_DIR [FEATURES...]}
shift 2
SIZES=("$@")
[ ${#SIZES[@]} -eq 0 ] && SIZES=(10000 100000 1000000)
POSES_PER_FEATURE=${POSES_PER_FEATURE:-1}
RUNS=${RUNS:-2}
ITERATIONS=${ITERATIONS:-1}
THREADS=${THREADS:-2}
CHUNK=${CHUNK:-4096}
MEMORY_LIMIT=${MEMORY_LIMIT:-8G}
INGEST_MEMORY_LIMIT=${INGEST_MEMORY_LIMIT:-}
if [ -n "$INGEST_MEMORY_LIMIT" ]; then
  INGEST_BUDGET=(--memory-limit "$INGEST_MEMORY_LIMIT")
else
  INGEST_BUDGET=(--buffer-observations 1165084)
fi
SEED=${SEED:-1}
SPEED=${SPEED:-8}
SOLVER=${SOLVER:-cholmod}
LANDMARK_SPACING=${LANDMARK_SPACING:-}
SENSOR_RANGE=${SENSOR_RANGE:-}
COMPRESS=${COMPRESS:-0}
SIM_EXTRA=()
[ -n "$LANDMARK_SPACING" ] && SIM_EXTRA+=(--landmark-spacing $LANDMARK_SPACING)
[ -n "$SENSOR_RANGE" ] && SIM_EXTRA+=(--sensor-range "$SENSOR_RANGE")
LOG_NAME=log.graphslam
[ "$COMPRESS" = 1 ] && SIM_EXTRA+=(--compress) && LOG_NAME=log.graphslam.zst
GS="$BUILD/bin/graphslam"
PLOT="$BUILD/bin/scaling_plot"
mkdir -p "$OUT"
CSV="$OUT/scaling.csv"
echo "features,observed_features,poses,observations,simulate_seconds,ingest_seconds,seconds_per_iteration,iterations,ingest_peak_rss_bytes,solve_peak_rss_bytes,store_bytes,chunks,final_chi2,chi2_per_dof,log_bytes,ingest_cpu_seconds,solve_cpu_seconds" > "$CSV"

# Peak RSS (bytes) and wall seconds of a command, from GNU time -v.
timed() {  # timed LOG cmd...
  local log=$1; shift
  /usr/bin/time -v "$@" > "$log.out" 2> "$log.time"
}
cpu_seconds() { awk -F': ' '/User time|System time/ {s+=$2} END {printf "%.1f\n", s}' "$1"; }
rss_bytes() { awk -F: '/Maximum resident set size/ {gsub(/ /,"",$2); printf "%.0f\n", $2*1024}' "$1"; }
wall_seconds() {
  awk -F': ' '/Elapsed \(wall clock\)/ {n=split($2,a,":"); s=0; for(i=1;i<=n;i++) s=s*60+a[i]; print s}' "$1"
}

for N in "${SIZES[@]}"; do
  P=$(python3 -c "print(max(1000, int($N * $POSES_PER_FEATURE)))")
  W="$OUT/n$N"
  rm -rf "$W"; mkdir -p "$W"
  echo "== $N features, $P poses" >&2
  timed "$W/simulate" "$GS" simulate -o "$W/sim" --features "$N" --poses "$P" --runs "$RUNS" --streaming \
    --speed "$SPEED" --gps-every 50 --seed "$SEED" "${SIM_EXTRA[@]}" -q
  SIM_S=$(wall_seconds "$W/simulate.time")
  LOG_BYTES=$(stat -c %s "$W/sim/$LOG_NAME")
  timed "$W/ingest" "$GS" ingest "$W/sim/$LOG_NAME" -o "$W/store" \
    --chunk-observations "$CHUNK" "${INGEST_BUDGET[@]}"
  INGEST_S=$(wall_seconds "$W/ingest.time")
  INGEST_RSS=$(rss_bytes "$W/ingest.time")
  INGEST_CPU=$(cpu_seconds "$W/ingest.time")
  rm -f "$W/sim/$LOG_NAME"   # the store is the input from here on
  STORE_BYTES=$(du -sb "$W/store" | cut -f1)
  set +e
  timed "$W/solve" "$GS" solve "$W/store" --streaming-poses 0 --initialization odometry \
    --max-iterations "$ITERATIONS" \
    --solver "$SOLVER" --threads "$THREADS" --chunk-observations "$CHUNK" --memory-limit "$MEMORY_LIMIT" \
    --report "$W/report.json" -q
  set -e
  SOLVE_RSS=$(rss_bytes "$W/solve.time")
  SOLVE_CPU=$(cpu_seconds "$W/solve.time")
  python3 - "$W/report.json" "$N" "$P" "$SIM_S" "$INGEST_S" "$INGEST_RSS" "$SOLVE_RSS" \
    "$STORE_BYTES" "$W/store/MANIFEST.json" "$LOG_BYTES" "$INGEST_CPU" "$SOLVE_CPU" >> "$CSV" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
manifest = json.load(open(sys.argv[9]))
log_bytes, ingest_cpu, solve_cpu = sys.argv[10:13]
n, p, sim_s, ingest_s, ingest_rss, solve_rss, store_bytes = sys.argv[2:9]
its = max(1, report["iterations"])
spi = report["stage_seconds"]["optimize"] / its
observed = report["features"] - report["unobserved_features"]
dof = report["residual_dimension"] - report["unknowns"]
print(",".join(str(v) for v in [n, observed, report["poses"], report["observations"], sim_s,
      ingest_s, "%.3f" % spi, report["iterations"], ingest_rss, solve_rss, store_bytes,
      manifest["num_chunks"], "%.6g" % report["final_chi2"],
      "%.4f" % (report["final_chi2"] / dof if dof > 0 else float("nan")),
      log_bytes, ingest_cpu, solve_cpu]))
PY
  tail -1 "$CSV" >&2
done

python3 - "$CSV" > "$OUT/scaling.md" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print("| features | observed | poses | observations | ingest s | s / iteration | ingest peak RSS MiB | solve peak RSS MiB | store MiB | chunks | chi2/dof after its |")
print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for r in rows:
    mib = lambda b: "%.0f" % (float(b) / 2**20)
    print("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s (%s) |" % (
        r["features"], r["observed_features"], r["poses"], r["observations"], r["ingest_seconds"],
        r["seconds_per_iteration"], mib(r["ingest_peak_rss_bytes"]), mib(r["solve_peak_rss_bytes"]),
        mib(r["store_bytes"]), r["chunks"], r["chi2_per_dof"], r["iterations"]))
PY
if [ -x "$PLOT" ]; then "$PLOT" "$CSV" "$OUT/scaling.png"; fi
cat "$OUT/scaling.md"
