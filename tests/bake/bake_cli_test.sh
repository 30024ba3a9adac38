#!/bin/sh
# End-to-end checks of the skelform-bake command line: every skinned sample bakes (and the
# Khronos validator reports 0 errors on each when node is available), the same input gives
# byte-identical output, and bad input exits with its documented code, leaving no file.
# usage: bake_cli_test.sh SKELFORM_BAKE DATA_DIR WORK_DIR TOOLS_DIR
set -u
bake=$1 data=$2 work=$3 tools=$4
rm -rf "$work" && mkdir -p "$work" || exit 1
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect CODE OUTPUT -- ARGS...: runs the baker, checks the exit code and that OUTPUT does not exist.
expect() {
  code=$1 output=$2; shift 3
  "$bake" "$@" >"$work/stdout" 2>"$work/stderr"
  rc=$?
  [ "$rc" -eq "$code" ] || fail "skelform-bake $* exited $rc, expected $code: $(cat "$work/stderr")"
  [ ! -e "$output" ] || fail "skelform-bake $* left $output behind"
  ls "$work" | grep -q 'tmp-skelform' && fail "skelform-bake $* left a temporary file"
  [ "$code" -eq 0 ] || [ "$(wc -l <"$work/stderr")" -le 2 ] || fail "error output is not one line: $(cat "$work/stderr")"
}

# --help states the defaults the baker uses (BakeOptions), with no placeholder left.
"$bake" --help >"$work/help" 2>&1 || fail "skelform-bake --help failed"
grep -q -- "--target-triangles N        control-mesh triangles (default 2000;" "$work/help" ||
  fail "--help does not give the control mesh's default: $(grep -- --target-triangles "$work/help")"
grep -q "%" "$work/help" && fail "--help has a placeholder left: $(grep "%" "$work/help")"

# Bad command lines and bad input files: a message, the documented exit code, no output.
expect 1 "$work/x.glb" -- --no-such-flag
expect 1 "$work/x.glb" -- "$work/missing.glb"
expect 3 "$work/x.glb" -- "$work/missing.glb" -o "$work/x.glb"
printf 'glTF' >"$work/truncated.glb"
expect 2 "$work/x.glb" -- "$work/truncated.glb" -o "$work/x.glb"
# A valid glTF without skins.
cat >"$work/noskin.gltf" <<'JSON'
{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],
 "accessors":[{"bufferView":0,"componentType":5126,"type":"VEC3","count":3}],
 "bufferViews":[{"buffer":0,"byteLength":36}],
 "buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]}
JSON
expect 2 "$work/x.glb" -- "$work/noskin.gltf" -o "$work/x.glb"
grep -q "no skinned mesh" "$work/stderr" || fail "no-skin message missing: $(cat "$work/stderr")"
# An accessor running past its buffer.
sed 's/"count":3/"count":4/' "$work/noskin.gltf" >"$work/overrun.gltf"
expect 2 "$work/x.glb" -- "$work/overrun.gltf" -o "$work/x.glb" --all-meshes
# The input is never overwritten, and a failed bake leaves an existing output untouched.
if [ -f "$data/Fox/Fox.glb" ]; then
  cp "$data/Fox/Fox.glb" "$work/fox-copy.glb"
  "$bake" "$work/fox-copy.glb" -o "$work/fox-copy.glb" -q 2>/dev/null && fail "baking onto the input succeeded"
  cmp -s "$data/Fox/Fox.glb" "$work/fox-copy.glb" || fail "the input was modified"
  echo "keep me" >"$work/existing.glb"
  "$bake" "$work/truncated.glb" -o "$work/existing.glb" -q 2>/dev/null
  [ "$(cat "$work/existing.glb")" = "keep me" ] || fail "a failed bake replaced an existing output"
fi

# Every skinned sample bakes; twice gives the same bytes.
baked=0
for model in RiggedSimple/RiggedSimple.glb RiggedFigure/RiggedFigure.glb SimpleSkin/SimpleSkin.gltf Fox/Fox.glb \
             CesiumMan/CesiumMan.glb; do
  [ -f "$data/$model" ] || { echo "skipped: $data/$model not found"; continue; }
  name=$(basename "${model%.*}")
  "$bake" "$data/$model" -o "$work/$name.skf.glb" || { fail "baking $model"; continue; }
  "$bake" "$data/$model" -o "$work/$name.again.glb" -q || fail "baking $model again"
  cmp -s "$work/$name.skf.glb" "$work/$name.again.glb" || fail "$model: two bakes differ"
  rm -f "$work/$name.again.glb"
  baked=$((baked + 1))
done
if [ "$baked" -gt 0 ]; then
  if command -v node >/dev/null 2>&1 && [ -d "$tools/node_modules/gltf-validator" ]; then
    node "$tools/validate-gltf.js" "$work"/*.skf.glb >"$work/validator.log" || fail "the validator reported errors"
    grep -v UNUSED_OBJECT "$work/validator.log"
  else
    echo "validator skipped: node or tools/node_modules missing (cd tools && npm ci)"
  fi
fi
echo "$baked samples baked; $failures failures"
[ "$failures" -eq 0 ]
