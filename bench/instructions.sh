#!/usr/bin/env bash
# Instructions per conversion for the headline jobs, counted by valgrind's cachegrind on one
# thread: a deterministic measure where timings are not (a shared host's timings move by
# ±40 % between minutes; instruction counts do not move at all). It says nothing of memory
# stalls, so it ranks changes to the arithmetic, not to the access pattern.
#
# Usage: bash bench/instructions.sh [JOB ...]   (jobs: J1 J2 J3 J4 DEF RT; default: all)
# Needs valgrind (Debian: valgrind). Each job runs `rs_timing` with one and with two rounds
# (a round is two conversions) and prints half the difference: the cost of one conversion,
# without the set-up (the source's random fill, the process). RS_TIMING=path runs that binary
# instead of building this tree's (to compare two builds).
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || { echo "needs valgrind (apt-get install valgrind)" >&2; exit 2; }
bin=${RS_TIMING:-}
if [ -z "$bin" ]; then
  cargo build --release -q -p spheremap --example rs_timing
  bin=target/release/examples/rs_timing
fi
declare -A job=(
  [J1]="latlong 2048 1024 sphere 1024 1 1"
  [J2]="cube 512 3072 sphere 1024 1 1"
  [J3]="sphere 1024 1024 latlong 1024 1 1"
  [J4]="latlong 2048 1024 sphere 1024 16 16"
  [DEF]="latlong 2048 1024 sphere 1024 4 1024"
  [RT]="cube 256 1536 sphere 512 1 1"
)
count() {
  RAYON_NUM_THREADS=1 valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
    "$bin" $1 "$2" 2>&1 | sed -nE 's/.*I +refs: +([0-9,]+).*/\1/p' | tr -d ,
}
for j in "${@:-J1 J2 J3 J4 DEF RT}"; do
  for k in $j; do
    [ -n "${job[$k]:-}" ] || { echo "unknown job $k (jobs: ${!job[*]})" >&2; exit 2; }
    a=$(count "${job[$k]}" 1); b=$(count "${job[$k]}" 2)
    printf '%-4s %s: %d M instructions per conversion\n' "$k" "${job[$k]}" $(( (b - a) / 2 / 1000000 ))
  done
done
