#!/bin/sh
# Opens skelform-animate files in the web viewer: installs three.js once (npm ci, pinned in
# package-lock.json), then serves the viewer on 127.0.0.1 and prints the URL to open.
#   samples/viewer/serve.sh [FILE.glb ...] [--port N]
set -eu
dir=$(cd "$(dirname "$0")" && pwd)
if ! command -v node >/dev/null 2>&1; then
  echo "serve.sh: node is not installed (apt-get install nodejs npm)" >&2
  exit 1
fi
if [ ! -f "$dir/node_modules/three/build/three.module.js" ]; then
  echo "==> npm ci (samples/viewer: three.js)"
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
fi
exec node "$dir/serve.js" "$@"
