#!/usr/bin/env bash
# Runs every libFuzzer target of fuzz/ (built by `make fuzz`) for SECONDS each (or RUNS executions), starting from
# fuzz/corpus/<target> + fuzz/regressions/<target>, and prints a Markdown table: executions, coverage, findings.
# Findings (crash-*, leak-*, timeout-*, oom-* files) are left in <build>/fuzz-findings/<target>/; add each to
# fuzz/regressions/<target>/ once fixed, so that `make test` replays it.
#   usage: scripts/run-fuzzers.sh BUILD_DIR [SECONDS] [RUNS] [TARGET...]   (FUZZ_MAX_LEN: input size, 4096)
set -euo pipefail
build=${1:?build dir}
seconds=${2:-60}
runs=${3:--1}
shift $(( $# < 3 ? $# : 3 ))
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(pickle checkpoint safetensors npy image exif mapfree_text submission correspondence pth_structured header_structured tracking_poses multipart service_fields options_file)
src=$(cd "$(dirname "$0")/.." && pwd)
# A folder without the targets (a mistyped build folder, or a target name given first) would give a table of zeros.
if [ ! -d "$build/fuzz" ]; then
  echo "run-fuzzers.sh: $build has no fuzz/ folder: give the fuzz build folder first (make fuzz builds build-fuzz)" >&2
  exit 2
fi
for t in "${targets[@]}"; do
  if [ ! -x "$build/fuzz/fuzz_$t" ]; then
    echo "run-fuzzers.sh: $build/fuzz/fuzz_$t is not built: build it (cmake --build $build --target fuzz_$t)" >&2
    exit 2
  fi
done
echo "| target | seconds | executions | exec/s | coverage (edges) | features | findings |"
echo "|---|---:|---:|---:|---:|---:|---:|"
for t in "${targets[@]}"; do
  work="$build/fuzz-work/$t"; found="$build/fuzz-findings/$t"
  mkdir -p "$work" "$found"
  seeds=("$src/fuzz/corpus/$t")
  [ -d "$src/fuzz/regressions/$t" ] && seeds+=("$src/fuzz/regressions/$t")
  log="$build/fuzz-$t.log"
  start=$(date +%s)
  FREELOC_FUZZ_TMP="$work" "$build/fuzz/fuzz_$t" -max_total_time="$seconds" -runs="$runs" -rss_limit_mb=2048 \
    -timeout=20 -max_len="${FUZZ_MAX_LEN:-4096}" -print_final_stats=1 -artifact_prefix="$found/" "$work" "${seeds[@]}" >"$log" 2>&1 || true
  elapsed=$(( $(date +%s) - start ))
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo 0)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo 0)
  findings=$(find "$found" -type f | wc -l)
  echo "| $t | $elapsed | $execs | $rate | $cov | $ft | $findings |"
done
