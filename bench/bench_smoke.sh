#!/bin/sh
# CTest bench_smoke: skelform-bench --json --smoke must print one JSON line per mesh (2-3) with
# every method's figure, --crowd 4 --smoke its line, --frames CesiumMan 2 and 0 theirs (and with
# --runs 2 its timed line), and --frames refuses an unknown or empty mesh, a negative count, a
# second --frames and another option. Skips (77) without the shared data.
#
#   bench_smoke.sh SKELFORM_BENCH DATA_DIR
BENCH=$1 DATA=${SKELFORM_DATA_DIR:-$2}
if [ ! -f "$DATA/CesiumMan/CesiumMan.glb" ]; then
  echo "skipped: $DATA/CesiumMan/CesiumMan.glb not found (set SKELFORM_DATA_DIR)"
  exit 77
fi
out=$("$BENCH" --json --smoke) || { echo "FAIL: skelform-bench exited $?"; exit 1; }
echo "$out"
lines=$(printf '%s\n' "$out" | grep -c '^{"mesh": ".*", "vertices": [0-9]*, "ms": {"skelform": [0-9.]*, "skelform_unfaired": [0-9.]*, "skelform_semi_implicit": [0-9.]*, "skelform_no_contacts": [0-9.]*, "lbs_optimised": [0-9.]*, "lbs": [0-9.]*, "lbs_range": [0-9.]*, "dqs": [0-9.]*, "delta_mush": [0-9.]*}}$')
total=$(printf '%s\n' "$out" | grep -c .)
# CesiumMan and its refinement always; the Quaternius Horse when the corpus is there.
expected=2
[ -f "$DATA/quaternius/animals_pack/Horse.glb" ] && expected=3
if [ "$lines" -ne "$expected" ] || [ "$total" -ne "$expected" ]; then
  echo "FAIL: expected $expected JSON lines, got $lines of $total lines"
  exit 1
fi
# --crowd: one JSON line with both figures.
crowd=$("$BENCH" --crowd 4 --smoke) || { echo "FAIL: skelform-bench --crowd exited $?"; exit 1; }
echo "$crowd"
printf '%s\n' "$crowd" | grep -q '^{"crowd": 4, "mesh": "CesiumMan_loop1", "vertices": [0-9]*, "threads": [0-9]*, "frames": 3, "ms_per_frame": {"skelform": [0-9.]*, "lbs_optimised": [0-9.]*}}$' \
  || { echo "FAIL: unexpected --crowd output"; exit 1; }
# --frames: one line, and an unknown mesh is refused.
frames=$("$BENCH" --frames CesiumMan 2 2>/dev/null) || { echo "FAIL: skelform-bench --frames exited $?"; exit 1; }
echo "$frames"
printf '%s\n' "$frames" | grep -q '^{"mesh": "CesiumMan", "vertices": 3273, "frames": 2}$' \
  || { echo "FAIL: unexpected --frames output"; exit 1; }
if "$BENCH" --frames NoSuchMesh 2 >/dev/null 2>&1; then echo "FAIL: --frames took an unknown mesh"; exit 1; fi
# --frames MESH 0: set up only; a negative count, an empty mesh name and --frames twice are refused.
frames=$("$BENCH" --frames CesiumMan 0 2>/dev/null) || { echo "FAIL: skelform-bench --frames CesiumMan 0 exited $?"; exit 1; }
printf '%s\n' "$frames" | grep -q '^{"mesh": "CesiumMan", "vertices": 3273, "frames": 0}$' \
  || { echo "FAIL: unexpected --frames CesiumMan 0 output"; exit 1; }
if "$BENCH" --frames CesiumMan -1 >/dev/null 2>&1; then echo "FAIL: --frames took -1 frames"; exit 1; fi
if "$BENCH" --frames "" 2 >/dev/null 2>&1; then echo "FAIL: --frames took an empty mesh name"; exit 1; fi
if "$BENCH" --frames CesiumMan 1 --frames Horse 1 >/dev/null 2>&1; then echo "FAIL: --frames given twice"; exit 1; fi
# --frames MESH N --runs R: the timed passes' best and median; another option is refused.
frames=$("$BENCH" --frames CesiumMan 2 --runs 2 2>/dev/null) || { echo "FAIL: --frames CesiumMan 2 --runs 2 exited $?"; exit 1; }
echo "$frames"
printf '%s\n' "$frames" | grep -q '^{"mesh": "CesiumMan", "vertices": 3273, "frames": 2, "runs": 2, "us_best": [0-9.]*, "us_median": [0-9.]*}$' \
  || { echo "FAIL: unexpected --frames --runs output"; exit 1; }
if "$BENCH" --frames CesiumMan 1 --cpu >/dev/null 2>&1; then echo "FAIL: --frames took --cpu"; exit 1; fi
if "$BENCH" --frames CesiumMan 0 --runs 2 >/dev/null 2>&1; then echo "FAIL: --frames MESH 0 took --runs"; exit 1; fi
