#!/usr/bin/env bash
# Instructions per warm skelform evaluation on the bench's meshes, counted by callgrind: a
# count that does not vary with the machine's load, for comparing two builds of one change
# (time on a shared 2-core machine varies by a third between sessions; docs/results.md).
# Instructions are not time: an AVX2 gather is one instruction and costs about one load per
# lane, and forms that gathered ran fewer instructions in more time. Judge a change by time too:
# `skelform-bench --frames MESH N --runs R` in turns with the build before (the best of the
# passes), and a kernel by timing its forms on the same data.
#
#   bench/instructions.sh [SKELFORM_BENCH [FILE...]]   default build/bench/skelform-bench
#
# FILEs: skinned glTF files (a corpus character, your own) counted after the bench's meshes, the
# same way over frames 5 to 24 of their first animation, baked with the defaults.
#
# For each mesh: skelform-bench --frames MESH N under callgrind, with N, 4, 3, 1 and 0 frames.
# The bench's first evaluation is a fresh start, as after a pose jump: its convergence is spread
# over that evaluation and the two after it (instance.h kFreshStartChunks). So the difference of
# N and 4 over N − 4 is one warm evaluation; that of 1 and 0, the fresh start's own evaluation;
# that of 3 and 1 over 2, each of the two that go on with its convergence. Needs valgrind and the
# shared data (SKELFORM_DATA_DIR); about a minute and a half.
set -euo pipefail
bench=${1:-build/bench/skelform-bench}
shift $(($# > 0 ? 1 : 0))
meshes=("CesiumMan 41" "CesiumMan_loop2 8" "Horse 41")
for file in "$@"; do
  [ -f "$file" ] || { echo "instructions.sh: $file not found" >&2; exit 1; }
  case "$file" in *" "*) echo "instructions.sh: $file: a path with spaces is not supported" >&2; exit 1 ;; esac
  meshes+=("$file 24")
done
command -v valgrind >/dev/null || { echo "instructions.sh: valgrind not found (apt install valgrind)" >&2; exit 1; }
[ -x "$bench" ] || { echo "instructions.sh: $bench not found (build the skelform-bench target)" >&2; exit 1; }
# Bake the cached models first, outside callgrind (a no-op when they are cached): a bake inside
# the first count alone would be counted as evaluations.
for case in "${meshes[@]}"; do "$bench" --frames "${case% *}" 1 >/dev/null; done
count() {  # mesh frames -> instructions
  valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bench" --frames "$1" "$2" 2>&1 >/dev/null |
    awk '/Collected/ {print $4}'
}
for case in "${meshes[@]}"; do
  set -- $case
  many=$(count "$1" "$2")
  four=$(count "$1" 4)
  three=$(count "$1" 3)
  one=$(count "$1" 1)
  none=$(count "$1" 0)
  [ -n "$many" ] && [ -n "$four" ] && [ -n "$three" ] && [ -n "$one" ] && [ -n "$none" ] ||
    { echo "instructions.sh: callgrind gave no count for $1" >&2; exit 1; }
  awk -v m="${1##*/}" -v a="$many" -v d="$four" -v t="$three" -v b="$one" -v c="$none" -v n="$2" 'BEGIN {
    warm = (a - d) / 1e6 / (n - 4); first = (b - c) / 1e6; next_two = (t - b) / 1e6 / 2
    printf "%-16s %8.2f M instructions per evaluation; a fresh start %8.2f M (%.0fx), the next two %8.2f M each\n",
           m, warm, first, first / warm, next_two }'
done
