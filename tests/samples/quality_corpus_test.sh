#!/bin/sh
# The quality corpus in CI: skelform-quality --check over every character of the shared data
# (../shared/data/quaternius, the Khronos samples) and the procedural character, every
# animation, 9 frames each; fails when an acceptance line breaks (every line, the pair share
# included). The report is kept in WORK.
#   quality_corpus_test.sh SKELFORM_QUALITY SKELFORM_CHARACTER DATA_DIR WORK_DIR
set -u
QUALITY=$1 CHARACTER=$2 DATA=$3 WORK=$4
if [ ! -d "$DATA/quaternius" ]; then
  echo "skipped: $DATA/quaternius not found (set SKELFORM_DATA_DIR)"
  exit 77
fi
rm -rf "$WORK" && mkdir -p "$WORK"
"$CHARACTER" -o "$WORK/character.glb" >/dev/null || { echo "FAIL: skelform-character"; exit 1; }
inputs="$DATA/quaternius $WORK/character.glb"
for sample in CesiumMan/CesiumMan.glb Fox/Fox.glb RiggedFigure/RiggedFigure.glb RiggedSimple/RiggedSimple.glb \
              SimpleSkin/SimpleSkin.gltf; do
  [ -f "$DATA/$sample" ] && inputs="$inputs $DATA/$sample"
done
# shellcheck disable=SC2086
"$QUALITY" $inputs --frames 9 --check -q >"$WORK/report.txt"
code=$?
cat "$WORK/report.txt"
exit $code
