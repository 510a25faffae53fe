#!/usr/bin/env bash
# Start-up cost of `freeloc` commands as whole processes (wall seconds and peak RSS from /usr/bin/time, median of
# R runs), side by side with the same command when LibTorch is loaded at start-up as it was before the networks
# became a module (LD_PRELOAD of libfreeloc_networks.so, which pulls LibTorch in). Data: the bundled TUM pair s00003
# and its committed SIFT correspondences.
# Usage: bench/startup.sh [BUILD_DIR] [RUNS]   (prints a Markdown table)
set -euo pipefail
build="${1:-build}"; runs="${2:-5}"
bin="$build/freeloc"; root="$(cd "$(dirname "$0")/.." && pwd)"
scene="$root/data/demo/val/s00003"; k=535.4,539.2,320.1,247.6
matches="$root/tests/data/tum_sift/s00003_sift_matches.txt"
preload="$(cd "$build/lib" && pwd)/libfreeloc_networks.so"
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
[ -x /usr/bin/time ] || { echo "bench/startup.sh: needs /usr/bin/time (Debian package 'time')" >&2; exit 1; }

# median wall seconds and median peak RSS (MB) of `runs` runs of "$@"
measure() {
  local w=() m=()
  for ((i = 0; i < runs; ++i)); do
    /usr/bin/time -f "%e %M" -o "$work/t" "$@" >/dev/null 2>&1 || true
    read -r e kb < "$work/t"; w+=("$e"); m+=("$kb")
  done
  local mw mm
  mw=$(printf '%s\n' "${w[@]}" | sort -g | sed -n "$(( (runs + 1) / 2 ))p")
  mm=$(printf '%s\n' "${m[@]}" | sort -g | sed -n "$(( (runs + 1) / 2 ))p")
  printf '%.3f s, %.0f MB' "$mw" "$(echo "$mm / 1024" | bc -l)"
}
pose=("$bin" pose --matches "$matches" --ref-intrinsics "$k" --query-intrinsics "$k"
      --ref-depth "$scene/seq0/frame_00000.sensor.png" --query-depth "$scene/seq1/frame_00000.sensor.png")
loop40=(bash -c 'for ((j = 0; j < 40; ++j)); do "$@" >/dev/null 2>&1; done' loop40)

echo "CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | xargs) ($(nproc) cores); BLAS: $(readlink -f /usr/lib/x86_64-linux-gnu/libblas.so.3 2>/dev/null || echo unknown)"
echo
echo "## bench/startup — whole processes, median of $runs"
echo
echo "| command | now (networks loaded on first use) | LibTorch loaded at start (as before) | target |"
echo "|---|---|---|---|"
echo "| \`freeloc --version\` | $(measure "$bin" --version) | $(measure env LD_PRELOAD="$preload" "$bin" --version) | ≤ 0.1 s, ≤ 50 MB |"
echo "| \`freeloc --help\` | $(measure "$bin" --help) | $(measure env LD_PRELOAD="$preload" "$bin" --help) | |"
echo "| \`freeloc pose\`, one pair with both depth PNGs | $(measure "${pose[@]}") | $(measure env LD_PRELOAD="$preload" "${pose[@]}") | ≤ 0.1 s, ≤ 50 MB |"
echo "| 40 × \`freeloc pose\` (total) | $(measure "${loop40[@]}" "${pose[@]}" | cut -d, -f1) | $(measure "${loop40[@]}" env LD_PRELOAD="$preload" "${pose[@]}" | cut -d, -f1) | |"
echo "| \`freeloc run --preset sift-essential\` on s00003 | $(measure "$bin" -q run --preset sift-essential --data "$root/data/demo" --scenes s00003 --out "$work/s.zip") | $(measure env LD_PRELOAD="$preload" "$bin" -q run --preset sift-essential --data "$root/data/demo" --scenes s00003 --out "$work/s.zip") | |"
