#!/usr/bin/env bash
# Instructions per warm skelform evaluation on the bench's meshes, counted by callgrind: a
# count that does not vary with the machine's load, for comparing two builds of one change
# (time on a shared 2-core machine varies by a third between sessions; docs/results.md).
#
#   bench/instructions.sh [SKELFORM_BENCH]   default build/bench/skelform-bench
#
# For each mesh: skelform-bench --frames MESH N under callgrind, with N, 1 and 0 frames. The
# difference of N and 1 over N − 1 is one warm evaluation (setup and the first, converging one
# cancel); that of 1 and 0 is the first evaluation, a fresh start as after a pose jump, which
# runs the fairing to convergence. Needs valgrind and the shared data (SKELFORM_DATA_DIR);
# about a minute.
set -euo pipefail
bench=${1:-build/bench/skelform-bench}
command -v valgrind >/dev/null || { echo "instructions.sh: valgrind not found (apt install valgrind)" >&2; exit 1; }
[ -x "$bench" ] || { echo "instructions.sh: $bench not found (build the skelform-bench target)" >&2; exit 1; }
# Bake the cached models first, outside callgrind (a no-op when they are cached).
"$bench" --frames CesiumMan_loop2 1 >/dev/null
count() {  # mesh frames -> instructions
  valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bench" --frames "$1" "$2" 2>&1 >/dev/null |
    awk '/Collected/ {print $4}'
}
for case in "CesiumMan 41" "CesiumMan_loop2 6" "Horse 41"; do
  set -- $case
  many=$(count "$1" "$2")
  one=$(count "$1" 1)
  none=$(count "$1" 0)
  [ -n "$many" ] && [ -n "$one" ] && [ -n "$none" ] || { echo "instructions.sh: callgrind gave no count for $1" >&2; exit 1; }
  awk -v m="$1" -v a="$many" -v b="$one" -v c="$none" -v n="$2" 'BEGIN {
    warm = (a - b) / 1e6 / (n - 1); first = (b - c) / 1e6
    printf "%-16s %8.2f M instructions per evaluation, first evaluation %8.2f M (%.0fx)\n", m, warm, first, first / warm }'
done
