#!/bin/sh
# skelform-c-engine end to end (samples/c_engine): bake a model with skelform-bake, run the C
# example on it, and check what it must show:
# - exit status 0 (it exits non-zero itself when any call or output check fails: non-finite
#   positions, normals not of unit length, bytes outside the written streams touched, an
#   error path that did not return its code, a bind pose that does not give identity
#   skinning matrices);
# - the joint hierarchy the example's GLB reader found (count, roots, depth) is the model's;
# - every deliberate error path printed with its expected code;
# - "allocations outstanding: 0" and "all positions finite";
# - the procedural pose really bends the model: the boxes reach beyond the rest pose's;
# - bad usage exits 2 and a missing file exits 1.
#
#   c_engine_test.sh capsule   SKELFORM_BAKE C_ENGINE CAPSULE_WRITER WORK_DIR
#   c_engine_test.sh cesiumman SKELFORM_BAKE C_ENGINE DATA_DIR WORK_DIR      (77 when absent)
set -u
MODE=$1 BAKE=$2 ENGINE=$3
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

case "$MODE" in
  capsule)
    WORK=$5
    rm -rf "$WORK" && mkdir -p "$WORK" || exit 1
    "$4" "$WORK/capsule.glb" || { echo "FAIL: writing the procedural capsule"; exit 1; }
    MODEL=$WORK/capsule.glb
    AXIS=y REST_MAX=0.25  # capsule radius 0.25 about the z axis; the sphere (r 0.15) is inside that
    SKIN="2 joints, 1 root(s), hierarchy depth 1"
    BENT_MAX=0.3          # the tip joint bends about x by up to 0.35 rad: the sphere at z 1.1 moves ~0.38 in y
    ;;
  cesiumman)
    DATA=${SKELFORM_DATA_DIR:-$4} WORK=$5
    MODEL=$DATA/CesiumMan/CesiumMan.glb
    if [ ! -f "$MODEL" ]; then
      echo "skipped: $MODEL not found (set SKELFORM_DATA_DIR)"
      exit 77
    fi
    rm -rf "$WORK" && mkdir -p "$WORK" || exit 1
    AXIS=x REST_MAX=0.181 # CesiumMan at bind (z up, arms along y): x in [-0.131, 0.181]
    SKIN="19 joints, 1 root(s), hierarchy depth 5"   # CesiumMan.glb's skin, read independently
    BENT_MAX=0.25         # bending its joints about their local x axes swings it forward, past 0.3
    ;;
  *) echo "usage: c_engine_test.sh capsule|cesiumman ..."; exit 2 ;;
esac

"$BAKE" -q "$MODEL" -o "$WORK/baked.glb" || { echo "FAIL: skelform-bake $MODEL"; exit 1; }
"$ENGINE" "$WORK/baked.glb" 12 >"$WORK/stdout" 2>"$WORK/stderr"
code=$?
cat "$WORK/stdout"
[ "$code" -eq 0 ] || fail "exit status $code: $(cat "$WORK/stderr")"
grep -q "^skin 0: $SKIN\$" "$WORK/stdout" || fail "the joint hierarchy read is not '$SKIN'"
grep -q "allocations outstanding: 0 (0 bytes)" "$WORK/stdout" || fail "allocations outstanding"
grep -q "^output check: 0 .*all positions finite" "$WORK/stdout" || fail "output check"
[ "$(grep -c '^  frame ' "$WORK/stdout")" -eq 12 ] || fail "not 12 frame lines"
for expected in "missing file) *-> SF_ERROR_IO" "truncated file) *-> SF_ERROR_INVALID_DATA" \
                "majorVersion 9) *-> SF_ERROR_VERSION_MISMATCH" "refuses) *-> SF_ERROR_OUT_OF_MEMORY" \
                "before evaluate) *-> SF_ERROR_NOT_READY" "count + 1) *-> SF_ERROR_INVALID_ARGUMENT" \
                "(NaN) *-> SF_ERROR_INVALID_ARGUMENT"; do
  grep -q "$expected" "$WORK/stdout" || fail "error path '$expected' not shown"
done
if [ "$MODE" = capsule ]; then
  grep -q "2 primitive(s)" "$WORK/stdout" || fail "the capsule asset should have 2 primitives"
  grep -q "none authored) *-> SF_ERROR_UNSUPPORTED" "$WORK/stdout" || fail "tangent error path not shown"
fi
# Largest coordinate on AXIS of any character's box over all frames ("#c [x y z .. X Y Z]").
column=$( [ "$AXIS" = x ] && echo 2 || echo 3 )
reach=$(grep '^  frame ' "$WORK/stdout" | grep -o '\.\. [^]]*' |
        awk -v c="$column" 'BEGIN { m = -1e30 } $c + 0 > m { m = $c + 0 } END { print m }')
awk -v r="$reach" -v lo="$BENT_MAX" 'BEGIN { exit !(r > lo) }' ||
  fail "largest $AXIS $reach: the pose did not bend the model past $BENT_MAX (rest: at most $REST_MAX)"

"$ENGINE" >/dev/null 2>&1
[ $? -eq 2 ] || fail "no argument: expected exit 2"
"$ENGINE" "$WORK/missing.glb" >/dev/null 2>&1
[ $? -eq 1 ] || fail "missing file: expected exit 1"

if [ "$failures" -ne 0 ]; then
  echo "$failures failure(s)"
  exit 1
fi
echo "c_engine ($MODE): all checks passed (largest $AXIS $reach, rest $REST_MAX)"
