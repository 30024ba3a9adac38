#!/bin/sh
# skelform-pose end to end: bake CesiumMan, pose it at rest with each method, check the OBJ's
# vertex count and that skelform's rest pose reproduces the original positions within
# 1e-5 × diagonal (DESIGN.md "rest error"); --anim and --handles run; bad arguments exit
# non-zero with exactly one line on stderr and leave no output file.
#
# The .glb output goes through the Khronos validator when tools/node_modules is installed.
#
#   pose_cli_test.sh SKELFORM_BAKE SKELFORM_POSE REST_CHECK DATA_DIR WORK_DIR [TOOLS_DIR]
set -u
BAKE=$1 POSE=$2 CHECK=$3 DATA=${SKELFORM_DATA_DIR:-$4} WORK=$5 TOOLS=${6:-}
MODEL=$DATA/CesiumMan/CesiumMan.glb
if [ ! -f "$MODEL" ]; then
  echo "skipped: $MODEL not found (set SKELFORM_DATA_DIR)"
  exit 77
fi
rm -rf "$WORK" && mkdir -p "$WORK" || exit 1
. "$(dirname "$0")/cli_test_lib.sh"  # failures, fail, expect_failure

"$BAKE" -q "$MODEL" -o "$WORK/cesium.skf.glb" || { echo "FAIL: bake"; exit 1; }

for method in skelform lbs dqs; do
  out=$WORK/rest_$method.obj
  if ! "$POSE" "$WORK/cesium.skf.glb" --rest --method $method -o "$out"; then
    fail "--rest --method $method"
    continue
  fi
  n=$(grep -c '^v ' "$out")
  [ "$n" -eq 3273 ] || fail "$method: $n vertices, expected 3273"
  nn=$(grep -c '^vn ' "$out")
  [ "$nn" -eq 3273 ] || fail "$method: $nn normals, expected 3273"
  grep -q '^f ' "$out" || fail "$method: no faces"
  "$CHECK" "$MODEL" "$out" 1e-5 || fail "$method: rest positions differ from the original"
done

# An animated frame and a GLB output.
"$POSE" -q "$WORK/cesium.skf.glb" --anim 0 --time 0.5 -o "$WORK/anim.obj" || fail "--anim 0 --time 0.5"
[ "$(grep -c '^v ' "$WORK/anim.obj" 2>/dev/null)" = 3273 ] || fail "--anim: vertex count"
"$POSE" -q "$WORK/cesium.skf.glb" --anim 0 --time 0.5 -o "$WORK/anim.glb" || fail "--anim to .glb"
head -c 4 "$WORK/anim.glb" 2>/dev/null | grep -q glTF || fail "the .glb output has no glTF magic"
if [ -n "$TOOLS" ] && [ -d "$TOOLS/node_modules/gltf-validator" ] && command -v node >/dev/null 2>&1; then
  node "$TOOLS/validate-gltf.js" "$WORK/anim.glb" || fail "the .glb output does not validate"
else
  echo "note: glTF-Validator not installed (npm ci in tools/); .glb output not validated"
fi
"$POSE" -q "$WORK/cesium.skf.glb" --bind -o "$WORK/bind.obj" || fail "--bind"

# Free-form handles: one moved vertex, one pinned.
cat > "$WORK/handles.json" <<'JSON'
{"handles": [{"vertex": 100, "target": [0.1, 0.2, 0.3]}], "pinned": [2000]}
JSON
"$POSE" -q "$WORK/cesium.skf.glb" --handles "$WORK/handles.json" -o "$WORK/handles.obj" || fail "--handles"

# Bad arguments: non-zero exit, one line on stderr, no output file.
bad() { expect_failure "$POSE" "$WORK/bad.obj" "$@"; }
bad 1 "$WORK/cesium.skf.glb" -o "$WORK/bad.obj"
bad 1 "$WORK/cesium.skf.glb" --rest --anim 0 --time 0 -o "$WORK/bad.obj"
bad 1 "$WORK/cesium.skf.glb" --rest --method fancy -o "$WORK/bad.obj"
bad 1 "$WORK/cesium.skf.glb" --anim 0 -o "$WORK/bad.obj"
bad 1 "$WORK/cesium.skf.glb" --anim 5 --time 0 -o "$WORK/bad.obj"
bad 1 "$WORK/cesium.skf.glb" --rest --deformable 3 -o "$WORK/bad.obj"
bad 1 "$WORK/cesium.skf.glb" --rest -o "$WORK/bad.ply"
bad 1 "$WORK/cesium.skf.glb" --rest
bad 1 --bogus
bad 3 "$WORK/missing.glb" --rest -o "$WORK/bad.obj"
bad 2 "$MODEL" --rest -o "$WORK/bad.obj"
echo '{"handles": [{"vertex": 100}]}' >"$WORK/bad_handles.json"
bad 2 "$WORK/cesium.skf.glb" --handles "$WORK/bad_handles.json" -o "$WORK/bad.obj"
echo '{"handles": [' >"$WORK/bad_handles.json"
bad 2 "$WORK/cesium.skf.glb" --handles "$WORK/bad_handles.json" -o "$WORK/bad.obj"
echo '{"handles": [{"vertex": 99999999, "target": [0, 0, 0]}]}' >"$WORK/bad_handles.json"
bad 2 "$WORK/cesium.skf.glb" --handles "$WORK/bad_handles.json" -o "$WORK/bad.obj"
bad 3 "$WORK/cesium.skf.glb" --handles "$WORK/none.json" -o "$WORK/bad.obj"
bad 3 "$WORK/cesium.skf.glb" --rest -o "$WORK/no/such/dir/out.obj"

if [ "$failures" -ne 0 ]; then
  echo "$failures failure(s)"
  exit 1
fi
echo "pose_cli: all checks passed"
