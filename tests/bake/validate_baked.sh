#!/bin/sh
# Runs the Khronos glTF-Validator on every baked sample the gltf_writer tests wrote.
# usage: validate_baked.sh TOOLS_DIR BAKED_DIR
# Exit: 0 no errors, 1 an error (or nothing to validate), 77 skipped (no node / validator).
tools=$1
baked=$2
if ! command -v node >/dev/null 2>&1; then
  echo "skipped: node not found (the Khronos glTF-Validator runs on Node.js)"
  exit 77
fi
if [ ! -d "$tools/node_modules/gltf-validator" ]; then
  echo "skipped: gltf-validator not installed (run: cd $tools && npm ci)"
  exit 77
fi
if [ -z "$(find "$baked" \( -name '*.glb' -o -name '*.gltf' \) 2>/dev/null | head -n 1)" ]; then
  echo "no baked files in $baked"
  exit 1
fi
find "$baked" \( -name '*.glb' -o -name '*.gltf' \) -print0 | sort -z |
  xargs -0 node "$tools/validate-gltf.js" || exit 1
