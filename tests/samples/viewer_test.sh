#!/bin/sh
# The web viewer (samples/viewer) in headless Chromium: viewer_browser_test.js on animation
# files, screenshots kept in WORK_DIR.
#
#   viewer_test.sh fixture VIEWER_DIR WORK_DIR
#       the contract's test fixture (viewer_fixture.js: a bending tube, no C++ tool needed)
#   viewer_test.sh animate VIEWER_DIR WORK_DIR SKELFORM_ANIMATE SKELFORM_CHARACTER DATA_DIR
#       skelform-animate on CesiumMan (from DATA_DIR; left out with a note when absent) and on
#       the procedural character (skelform-character -o character.glb)
#
# Exit 77 (skipped) without node, chromium or the viewer's node_modules (npm ci in
# samples/viewer; ./run.sh test installs all three), or when no input is available.
set -u
MODE=$1 VIEWER=$2 WORK=$3
HERE=$(cd "$(dirname "$0")" && pwd)
if ! command -v node >/dev/null 2>&1; then
  echo "skipped: node not installed"; exit 77
fi
if [ ! -x "${CHROMIUM:-/usr/bin/chromium}" ]; then
  echo "skipped: ${CHROMIUM:-/usr/bin/chromium} not installed (apt-get install chromium)"; exit 77
fi
if [ ! -d "$VIEWER/node_modules/three" ] || [ ! -d "$VIEWER/node_modules/playwright-core" ]; then
  echo "skipped: $VIEWER/node_modules missing (npm ci in samples/viewer)"; exit 77
fi
rm -rf "$WORK" && mkdir -p "$WORK" || exit 1

case "$MODE" in
  fixture)
    node "$HERE/viewer_fixture.js" "$WORK/tube.anim.glb" || { echo "FAIL: viewer_fixture.js"; exit 1; }
    exec node "$HERE/viewer_browser_test.js" "$WORK/screenshots" --tube "$WORK/tube.anim.glb"
    ;;
  animate)
    ANIMATE=$4 CHARACTER=$5 DATA=${SKELFORM_DATA_DIR:-$6}
    set --
    "$CHARACTER" -o "$WORK/character.glb" >/dev/null || { echo "FAIL: skelform-character -o character.glb"; exit 1; }
    "$ANIMATE" "$WORK/character.glb" -o "$WORK/character.anim.glb" || { echo "FAIL: skelform-animate character.glb"; exit 1; }
    set -- "$WORK/character.anim.glb"
    if [ -f "$DATA/CesiumMan/CesiumMan.glb" ]; then
      "$ANIMATE" "$DATA/CesiumMan/CesiumMan.glb" -o "$WORK/CesiumMan.anim.glb" || { echo "FAIL: skelform-animate CesiumMan.glb"; exit 1; }
      set -- "$WORK/CesiumMan.anim.glb" "$@"
    else
      echo "note: $DATA/CesiumMan/CesiumMan.glb not found (set SKELFORM_DATA_DIR): CesiumMan left out"
    fi
    exec node "$HERE/viewer_browser_test.js" "$WORK/screenshots" "$@"
    ;;
  *)
    echo "usage: viewer_test.sh fixture|animate VIEWER_DIR WORK_DIR [SKELFORM_ANIMATE SKELFORM_CHARACTER DATA_DIR]"; exit 2
    ;;
esac
