#!/bin/sh
# skelform-character -> skelform-animate end to end, and skelform-animate on the skinned
# samples of ../shared/data (each skipped when absent): every output passes the Khronos
# glTF-Validator with 0 errors and animate_check.js (the file contract; animation names and
# frame counts, for the samples derived from the source file itself); the same input gives
# the same bytes; an already baked input gives the same frames; a model without animation
# gives one rest frame; bad input and options exit with skelform-bake's codes, one line on
# stderr and no output file.
#
# Skipped (77) only when node or the validator (npm ci in tools/) is missing.
#
#   animate_cli_test.sh SKELFORM_CHARACTER SKELFORM_ANIMATE SKELFORM_BAKE DATA_DIR WORK_DIR TOOLS_DIR
set -u
CHARACTER=$1 ANIMATE=$2 BAKE=$3 DATA=${SKELFORM_DATA_DIR:-$4} WORK=$5 TOOLS=$6
CHECK=$(dirname "$0")/animate_check.js
if ! command -v node >/dev/null 2>&1 || [ ! -d "$TOOLS/node_modules/gltf-validator" ]; then
  echo "skipped: node or the glTF-Validator is missing (npm ci in tools/)"
  exit 77
fi
rm -rf "$WORK" && mkdir -p "$WORK" || exit 1
. "$(dirname "$0")/cli_test_lib.sh"  # failures, fail, expect_failure
validate() {
  node "$TOOLS/validate-gltf.js" "$1" >"$WORK/validator.txt" 2>&1 || { cat "$WORK/validator.txt"; fail "$1 does not validate"; }
  head -n 1 "$WORK/validator.txt"
}

# The procedural character: rigged glTF, then animated (baked in memory), twice.
"$CHARACTER" -o "$WORK/character.glb" || fail "skelform-character -o character.glb"
"$CHARACTER" -o "$WORK/character2.glb" >/dev/null || fail "skelform-character (second run)"
cmp -s "$WORK/character.glb" "$WORK/character2.glb" || fail "skelform-character is not deterministic"
validate "$WORK/character.glb"
"$ANIMATE" "$WORK/character.glb" -o "$WORK/character.anim.glb" || fail "skelform-animate character.glb"
validate "$WORK/character.anim.glb"
node "$CHECK" "$WORK/character.anim.glb" --animations walk,bend --frames 31,91 --source character.glb --fps 30 ||
  fail "character.anim.glb breaks the contract"
"$ANIMATE" -q "$WORK/character.glb" -o "$WORK/character.again.glb" || fail "skelform-animate (second run)"
cmp -s "$WORK/character.anim.glb" "$WORK/character.again.glb" || fail "skelform-animate is not deterministic"

# A baked input is played as it is: same frames (only the source name differs).
"$BAKE" -q "$WORK/character.glb" -o "$WORK/character.skf.glb" || fail "skelform-bake character.glb"
"$ANIMATE" -q "$WORK/character.skf.glb" -o "$WORK/baked.anim.glb" || fail "skelform-animate on a baked input"
node "$CHECK" "$WORK/baked.anim.glb" --animations walk,bend --frames 31,91 --source character.skf.glb >/dev/null ||
  fail "baked.anim.glb breaks the contract"
node -e '
  const fs = require("fs");
  const bin = (f) => { const b = fs.readFileSync(f); return b.subarray(20 + b.readUInt32LE(12)); };
  process.exitCode = bin(process.argv[1]).equals(bin(process.argv[2])) ? 0 : 1;' \
  "$WORK/baked.anim.glb" "$WORK/character.anim.glb" || fail "a baked input gives other frames than baking in memory"

# --no-contacts: the same contract (the LBS half is the same bits; the skelform half may differ
# only where the contact pass moved vertices), deterministic, valid.
"$ANIMATE" -q "$WORK/character.glb" -o "$WORK/contacts.anim.glb" --no-contacts --max-frames 8 || fail "--no-contacts"
"$ANIMATE" -q "$WORK/character.glb" -o "$WORK/contacts.again.glb" --no-contacts --max-frames 8 ||
  fail "--no-contacts (second run)"
cmp -s "$WORK/contacts.anim.glb" "$WORK/contacts.again.glb" || fail "skelform-animate --no-contacts is not deterministic"
node "$CHECK" "$WORK/contacts.anim.glb" --frames 8,8 >/dev/null || fail "contacts.anim.glb breaks the contract"
validate "$WORK/contacts.anim.glb"

# Frame times are stored as floats, strictly increasing: at 30.0000006 fps the bend's 3 s
# hold 91 frame steps and a bit, and the 91st step (2.99999994 s) rounds onto the end's float
# (3.0): it is dropped, 91 frames, as at 30 fps.
"$ANIMATE" -q "$WORK/character.glb" -o "$WORK/rounding.anim.glb" --fps 30.0000006 || fail "--fps 30.0000006"
validate "$WORK/rounding.anim.glb"
node "$CHECK" "$WORK/rounding.anim.glb" --frames 31,91 >/dev/null || fail "rounding.anim.glb: frame counts"

# --fps and --max-frames: walk 1 s at 10 fps = 11 frames, bend 3 s = 31, both capped at 5.
"$ANIMATE" -q "$WORK/character.glb" -o "$WORK/capped.anim.glb" --fps 10 --max-frames 5 || fail "--fps 10 --max-frames 5"
node "$CHECK" "$WORK/capped.anim.glb" --frames 5,5 --fps 10 >/dev/null || fail "capped.anim.glb: frame counts"
"$ANIMATE" -q "$WORK/character.glb" -o "$WORK/slow.anim.glb" --fps 10 || fail "--fps 10"
node "$CHECK" "$WORK/slow.anim.glb" --frames 11,31 --fps 10 >/dev/null || fail "slow.anim.glb: frame counts"
validate "$WORK/capped.anim.glb"

# No animation: one frame, the rest pose, and a note on stderr.
node "$CHECK" --strip animations "$WORK/character.glb" "$WORK/still.glb" || fail "strip animations"
"$ANIMATE" "$WORK/still.glb" -o "$WORK/still.anim.glb" 2>"$WORK/still.stderr" >/dev/null || fail "skelform-animate on a still model"
grep -q "no animation" "$WORK/still.stderr" || fail "no note about the missing animation"
node "$CHECK" "$WORK/still.anim.glb" --animations "rest pose" --frames 1 >/dev/null || fail "still.anim.glb: one rest frame"
validate "$WORK/still.anim.glb"

# The skinned samples, when present.
for model in CesiumMan/CesiumMan.glb Fox/Fox.glb RiggedFigure/RiggedFigure.glb; do
  if [ ! -f "$DATA/$model" ]; then
    echo "skipped: $DATA/$model not found (set SKELFORM_DATA_DIR)"
    continue
  fi
  name=$(basename "$model" .glb)
  "$ANIMATE" -q "$DATA/$model" -o "$WORK/$name.anim.glb" || { fail "skelform-animate $model"; continue; }
  validate "$WORK/$name.anim.glb"
  node "$CHECK" "$WORK/$name.anim.glb" --expect-from "$DATA/$model" --source "$name.glb" || fail "$name.anim.glb breaks the contract"
done

# Errors: exit code, exactly one line on stderr, no output file.
bad() { expect_failure "$ANIMATE" "$WORK/bad.glb" "$@"; }
node "$CHECK" --strip skins "$WORK/character.glb" "$WORK/unskinned.glb" || fail "strip skins"
printf 'not a model\n' >"$WORK/text.glb"
bad 3 -q "$WORK/missing.glb" -o "$WORK/bad.glb"
bad 2 -q "$WORK/unskinned.glb" -o "$WORK/bad.glb"
bad 2 -q "$WORK/text.glb" -o "$WORK/bad.glb"
bad 1 -q "$WORK/character.glb"
bad 1 -q "$WORK/character.glb" -o "$WORK/bad.obj"
bad 1 -q "$WORK/character.glb" -o "$WORK/bad.glb" --fps 0
bad 1 -q "$WORK/character.glb" -o "$WORK/bad.glb" --fps fast
bad 1 -q "$WORK/character.glb" -o "$WORK/bad.glb" --max-frames 0
bad 1 -q "$WORK/character.glb" -o "$WORK/bad.glb" --max-frames
bad 1 -q "$WORK/character.glb" "$WORK/still.glb" -o "$WORK/bad.glb"
bad 1 -q "$WORK/character.glb" -o "$WORK/bad.glb" --bogus
bad 1 -q "$WORK/character.glb" -o "$WORK/character.glb"
bad 3 -q "$WORK/character.glb" -o "$WORK/no/such/dir/bad.glb"

if [ "$failures" -ne 0 ]; then
  echo "$failures failure(s)"
  exit 1
fi
echo "animate_cli: all checks passed"
