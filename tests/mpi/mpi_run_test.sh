#!/usr/bin/env bash
# `mpirun -np N freeloc run`: the bundled TUM scenes plus copies of them (6 scenes) run with 3 and 2 ranks
# write the single-process submission and sidecar byte for byte and nothing else; a rank killed at start makes the
# run exit non-zero naming its scenes, and --resume (2 ranks) completes the same bytes. Exit 77 (skipped) when
# mpirun is absent. Then synthetic scenes whose queries are rolled 80–126° (where a pose read back from its record
# and written again once moved its last bit): 2 and 3 ranks, and every scene alone, write the one-process bytes.
# Usage: mpi_run_test.sh FREELOC_BINARY DEMO_DIR FAULT_RUN_BINARY MAKE_ROLLED_SCENES (tests/mpi/fault_run.cc: the same
# run, with the rank named by FREELOC_TEST_KILL_RANK killing itself once it has its scenes; make_rolled_scenes.cc)
set -uo pipefail
bin="$1"; demo="$2"; fault="$3"; rolled="$4"
if ! command -v mpirun >/dev/null 2>&1; then echo "skipped: mpirun is absent (install openmpi-bin)"; exit 77; fi
# Root in containers and CI; no CMA single-copy in containers; loopback only.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMPI_MCA_btl=self,vader OMPI_MCA_plm_rsh_agent=false
mpi=(mpirun --oversubscribe)
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
mkdir -p "$work/data/val"
for s in s00001 s00002 s00003; do cp -r "$demo/val/$s" "$work/data/val/"; done
cp -r "$demo/val/s00002" "$work/data/val/s00004"; cp -r "$demo/val/s00003" "$work/data/val/s00005"
cp -r "$demo/val/s00001" "$work/data/val/s00006"
run=(run --data "$work/data")

mkdir -p "$work/one"
"$bin" -q "${run[@]}" --out "$work/one/sub.zip" || fail "single-process run"
for n in 3 2; do
  mkdir -p "$work/np$n"
  out="$("${mpi[@]}" -np "$n" "$bin" -q "${run[@]}" --out "$work/np$n/sub.zip" 2>&1)" || fail "mpirun -np $n: $out"
  cmp "$work/one/sub.zip" "$work/np$n/sub.zip" || fail "-np $n: the submission differs from one process"
  cmp "$work/one/sub.zip.json" "$work/np$n/sub.zip.json" || fail "-np $n: the provenance sidecar differs"
  [ "$(ls "$work/np$n" | tr '\n' ' ')" = "sub.zip sub.zip.json " ] || fail "-np $n left other files: $(ls "$work/np$n")"
  echo "ok: mpirun -np $n writes the single-process bytes"
done

# A rank killed at start: non-zero exit, its scenes named; --resume with another N completes the same bytes.
mkdir -p "$work/kill"
out="$("${mpi[@]}" -x FREELOC_TEST_KILL_RANK=1 -np 3 "$fault" --data "$work/data" --out "$work/kill/sub.zip" 2>&1)"
code=$?
[ $code -ne 0 ] || fail "a killed rank left exit code 0"
echo "$out" | grep -q "rank 1 of 3: [0-9]* scenes (s0000" || fail "the killed rank's scenes are not named: $out"
[ ! -e "$work/kill/sub.zip" ] || fail "a failed run wrote a submission"
out="$("${mpi[@]}" -np 2 "$bin" "${run[@]}" --resume --out "$work/kill/sub.zip" 2>&1)" || fail "resume under mpirun: $out"
cmp "$work/one/sub.zip" "$work/kill/sub.zip" || fail "resumed run differs from one process"
[ ! -e "$work/kill/sub.zip.progress.jsonl" ] || fail "the journal was left behind"
echo "ok: killed rank → exit $code naming its scenes; --resume -np 2 completes the same bytes"
# Large rotations: 2 and 3 ranks, a --resume and each scene run alone write the one-process bytes.
"$rolled" "$work/rolled" 12 || fail "writing the rolled scenes"
rrun=(run --data "$work/rolled" --preset precomputed:SIFT-essential --depth provided:gt)
mkdir -p "$work/r1" "$work/r2" "$work/r3" "$work/ralone"
"$bin" -q "${rrun[@]}" --out "$work/r1/sub.zip" || fail "rolled: single-process run"
for n in 2 3; do
  out="$("${mpi[@]}" -np "$n" "$bin" -q "${rrun[@]}" --out "$work/r$n/sub.zip" 2>&1)" || fail "rolled -np $n: $out"
  cmp "$work/r1/sub.zip" "$work/r$n/sub.zip" || fail "rolled -np $n: the submission differs from one process"
done
one="$(unzip -p "$work/r1/sub.zip" | sort)"
alone=""
for s in $(ls "$work/rolled/val"); do
  "$bin" -q "${rrun[@]}" --scenes "$s" --out "$work/ralone/$s.zip" || fail "rolled: $s alone"
  alone+="$(unzip -p "$work/ralone/$s.zip")"$'\n'
done
[ "$one" = "$(printf '%s' "$alone" | grep -v '^$' | sort)" ] || fail "rolled: a scene run alone differs from the full run"
echo "ok: rolled scenes — mpirun -np 2 and 3 and each scene alone write the one-process bytes"
echo "4 passed, 0 failed"
