#!/usr/bin/env bash
# Builds the libFuzzer targets of every input parser (g2o, iSAM, MRCLAM,
# native log, job YAML, observation chunk; 3-D g2o, 3-D iSAM, 3DTK scans,
# scan store) with clang + ASan + UBSan in
# build-fuzz/, and runs each for a bounded time from its seed corpus
# (tests/fuzz/corpus/<target>/). Fails on any crash, hang (> 10 s for one
# input), leak or sanitizer report. Installs clang and libclang-rt-14-dev if
# missing (Debian, needs root).
#   FUZZ_SECONDS=60 tests/fuzz/run_fuzzers.sh         (default 30 s per target)
#   tests/fuzz/run_fuzzers.sh job_spec g2o_reader      (only these targets)
set -euo pipefail
cd "$(dirname "$0")/../.."
SECONDS_PER_TARGET=${FUZZ_SECONDS:-30}
BUILD=${FUZZ_BUILD_DIR:-build-fuzz}

missing=()
for p in clang libclang-rt-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

targets=("$@")
if ((${#targets[@]} == 0)); then
  targets=(g2o_reader isam_reader native_log_reader mrclam_reader job_spec chunk_reader
           g2o_3d_reader isam_3d_reader threedtk_reader scan_store)
fi

launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ "${launcher[@]}" \
  -DGRAPHSLAM_BUILD_FUZZERS=ON -DGRAPHSLAM_BUILD_TESTS=OFF -DGRAPHSLAM_BUILD_PERF=OFF >/dev/null
cmake --build "$BUILD" -j2 --target "${targets[@]/%/_fuzzer}"

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
status=0
for t in "${targets[@]}"; do
  work=$(mktemp -d)
  cp -r "tests/fuzz/corpus/$t/." "$work/"
  echo "== $t: ${SECONDS_PER_TARGET}s"
  if ! "$BUILD/bin/${t}_fuzzer" "$work" -max_total_time="$SECONDS_PER_TARGET" -timeout=10 \
        -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 \
        -artifact_prefix="$BUILD/${t}-" 2>"$BUILD/${t}.log"; then
    echo "FAILED: $t (see $BUILD/${t}.log and $BUILD/${t}-* artifacts)"
    tail -40 "$BUILD/${t}.log"
    status=1
  else
    grep -E "stat::number_of_executed_units|cov:" "$BUILD/${t}.log" | tail -2
  fi
  rm -rf "$work"
done
exit $status
