#!/usr/bin/env bash
# Queries per second of `freeloc run` (sift-essential, sensor depth) with 1 process and with 1, 2 MPI ranks, on
# scenes built from the bundled TUM frames (each scene: the s00002 reference and Q copies of its query).
# Usage: bench/mpi_throughput.sh [BUILD_DIR] [SCENES] [QUERIES_PER_SCENE]   (prints a Markdown table)
set -euo pipefail
build="${1:-build}"; scenes="${2:-12}"; q="${3:-8}"
bin="$build/freeloc"; demo="$(dirname "$0")/../data/demo/val/s00002"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMPI_MCA_btl=self,vader OMPI_MCA_plm_rsh_agent=false
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
for ((s = 1; s <= scenes; ++s)); do
  d="$work/data/val/$(printf 's%05d' "$s")"; mkdir -p "$d/seq0" "$d/seq1"
  cp "$demo"/seq0/* "$d/seq0/"
  ref_line="$(grep '^seq0/' "$demo/intrinsics.txt")"; q_line="$(grep '^seq1/' "$demo/intrinsics.txt")"
  ref_pose="$(grep '^seq0/' "$demo/poses.txt")"; q_pose="$(grep '^seq1/' "$demo/poses.txt")"
  echo "$ref_line" > "$d/intrinsics.txt"; echo "$ref_pose" > "$d/poses.txt"
  for ((k = 0; k < q; ++k)); do
    f="$(printf 'frame_%05d' "$k")"
    cp "$demo/seq1/frame_00000.png" "$d/seq1/$f.png"; cp "$demo/seq1/frame_00000.sensor.png" "$d/seq1/$f.sensor.png"
    echo "${q_line/frame_00000/$f}" >> "$d/intrinsics.txt"; echo "${q_pose/frame_00000/$f}" >> "$d/poses.txt"
  done
done
total=$((scenes * q))
time_of() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N); echo "$t1 - $t0" | bc -l; }
echo "CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | xargs) ($(nproc) cores); BLAS: $(readlink -f /usr/lib/x86_64-linux-gnu/libblas.so.3 2>/dev/null || echo unknown)"
echo "$scenes scenes × $q queries = $total queries, preset sift-essential, --threads 1 per process"
echo
echo "| processes | wall (s) | queries/s | speed-up |"
echo "|---|---|---|---|"
t1=$(time_of "$bin" --threads 1 -q run --data "$work/data" --out "$work/a.zip")
printf "| 1 (no MPI) | %.2f | %.2f | 1.00 |\n" "$t1" "$(echo "$total / $t1" | bc -l)"
for n in 1 2; do
  t=$(time_of mpirun --oversubscribe --bind-to none -np "$n" "$bin" --threads 1 -q run --data "$work/data" --out "$work/m$n.zip")
  cmp -s "$work/a.zip" "$work/m$n.zip" || { echo "mpirun -np $n wrote other bytes"; exit 1; }
  printf "| %d MPI rank%s | %.2f | %.2f | %.2f |\n" "$n" "$([ "$n" -gt 1 ] && echo s)" "$t" "$(echo "$total / $t" | bc -l)" \
    "$(echo "$t1 / $t" | bc -l)"
done
