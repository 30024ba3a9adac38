#!/usr/bin/env bash
# skelform: set up everything on a fresh Debian 12 machine and run.
#
#   ./run.sh                 install missing packages, build, run the main job: generate the
#                            project's own procedural character, rigged and animated in code
#                            (walk, deep bend), bake it and play its animations through
#                            skelform and LBS into out/character.anim.glb (a standard glTF
#                            any viewer plays), write its skeletal mesh as OBJ, and print
#                            the command that opens the web viewer
#   ./run.sh MODEL           the same main job on your own skinned glTF (.glb/.gltf) into
#                            out/MODEL.anim.glb; .obj/.ply/.off: the skeletal mesh only
#   ./run.sh test            install missing packages, check the sources' format
#                            (tools/format.sh), build, run the whole test suite, the
#                            runtime's own tests in a build without the baker,
#                            then again under AddressSanitizer + UndefinedBehaviorSanitizer,
#                            and the multi-threaded instance test under ThreadSanitizer
#                            (with the web viewer's browser test in headless chromium), again
#                            built by clang as a shared library for the machine's own ISA
#                            (-march=native), then each libFuzzer target (tests/fuzz) for 30 s
#   ./run.sh viewer FILE.glb...  serve the web viewer for skelform-animate files on 127.0.0.1
#                            and print the URL to open (installs three.js from npm once)
#   ./run.sh quality [ARGS]  skelform against LBS over the whole corpus (the Quaternius characters
#                            and Khronos samples of the data dir, and the procedural character):
#                            builds, runs skelform-quality --check and prints its table as
#                            Markdown (the README's); ARGS go to skelform-quality (e.g. --no-contacts)
#   ./run.sh speed [RUNS]    the README's speed table: skelform-bench --markdown (every method
#                            against the optimised LBS, CPU time, median of RUNS runs, default
#                            5; needs CesiumMan in the data dir; about 30 s per run)
#   ./run.sh screenshots     regenerate the README's pictures (docs/images/*.png) from the web
#                            viewer in headless chromium (needs CesiumMan, Fox and the
#                            Quaternius Horse in the data dir)
#
# Environment: JOBS (parallel build jobs, default: all cores), SKELFORM_DATA_DIR (the
# third-party models the tests read; default ../shared/data, tests skip when absent).
set -euo pipefail
cd "$(dirname "$0")"
root=$(pwd)
jobs=${JOBS:-$(nproc)}

apt_packages=(g++ cmake make pkg-config libglm-dev libtinygltf-dev nlohmann-json3-dev libstb-dev libosd-dev
              libeigen3-dev libqhull-dev doctest-dev libmeshoptimizer-dev libbenchmark-dev)

# Minutes:seconds since this script started, for the stage lines of a long run (CI's log
# then shows where its time goes).
since_start() { printf '%d:%02d' $((SECONDS / 60)) $((SECONDS % 60)); }

# apt-get install of the given packages (through sudo unless root).
apt_install() {
  local sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "==> installing: $*"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "$@"
}

install_missing_packages() {
  local missing=() p
  for p in "${apt_packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  apt_install "${missing[@]}"
}

# node and npm from Debian, for the validator and the viewer.
install_node() {
  if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then apt_install nodejs npm; fi
}

# The Khronos glTF-Validator (npm, pinned in tools/package-lock.json) checks every baked file.
install_validator() {
  install_node
  if [ ! -d "$root/tools/node_modules/gltf-validator" ]; then
    echo "==> npm ci (tools/: gltf-validator)"
    (cd "$root/tools" && npm ci --no-audit --no-fund --loglevel=error)
  fi
}

# build DIR [cmake args...] [--target T]
build() {
  local dir=$1; shift
  local configure=() target=()
  while [ $# -gt 0 ]; do
    if [ "$1" = "--target" ]; then target+=(--target "$2"); shift 2; else configure+=("$1"); shift; fi
  done
  echo "==> building in $dir (at $(since_start))"
  cmake -S "$root" -B "$dir" "${configure[@]}" >/dev/null
  cmake --build "$dir" -j "$jobs" "${target[@]}"
}

run_tests() {
  install_validator
  # Every C/C++ source as .clang-format lays it out (clang-format 14).
  dpkg-query -W -f='${Status}' clang-format-14 2>/dev/null | grep -q "install ok installed" || apt_install clang-format-14
  echo "==> format check (at $(since_start))"
  "$root/tools/format.sh" --check
  build "$root/build" -DCMAKE_BUILD_TYPE=Release
  echo "==> tests (Release) (at $(since_start))"
  ctest --test-dir "$root/build" --output-on-failure -j "$jobs"
  # The runtime alone, as a port without the baker's dependencies builds it: its tests that
  # need no baking, on the committed baked capsule (tests/data/README.md).
  build "$root/build-runtime" -DCMAKE_BUILD_TYPE=Release -DSKELFORM_BUILD_BAKE=OFF \
        -DSKELFORM_BUILD_SAMPLES=OFF -DSKELFORM_BUILD_BENCH=OFF
  echo "==> tests (runtime alone, SKELFORM_BUILD_BAKE=OFF) (at $(since_start))"
  ctest --test-dir "$root/build-runtime" --output-on-failure -j "$jobs"
  # -O1 -g, as AddressSanitizer's own docs advise: its build was CI's longest stage at -O2
  # (a heavy test file compiles in 50 s instead of 69), and reports keep their source lines.
  build "$root/build-asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSKELFORM_SANITIZE=address,undefined \
        -DCMAKE_C_FLAGS_RELWITHDEBINFO='-O1 -g -DNDEBUG' -DCMAKE_CXX_FLAGS_RELWITHDEBINFO='-O1 -g -DNDEBUG' \
        -DSKELFORM_BUILD_BENCH=OFF
  echo "==> tests (AddressSanitizer + UndefinedBehaviorSanitizer) (at $(since_start))"
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir "$root/build-asan" --output-on-failure -j "$jobs"
  # Instances evaluated on many threads at once must not race (DESIGN.md threading contract).
  build "$root/build-tsan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSKELFORM_SANITIZE=thread \
        -DSKELFORM_BUILD_BENCH=OFF -DSKELFORM_BUILD_SAMPLES=OFF -DSKELFORM_TEST_FILES='runtime/threads_test\.cpp' \
        --target skelform_tests
  echo "==> thread test (ThreadSanitizer) (at $(since_start))"
  TSAN_OPTIONS=halt_on_error=1 ctest --test-dir "$root/build-tsan" --output-on-failure -R 'runtime/threads_test'
  # What users build too: clang, libskelform as a shared library (the C API exported,
  # everything else hidden), and code for this machine's own ISA (FMA wherever the CPU has
  # it; the rest pose still matches the baker's bits because cmake/SkelformTargets.cmake turns
  # floating-point contraction off): the whole suite once more.
  local clang_missing=() p
  for p in clang-14 libclang-rt-14-dev; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || clang_missing+=("$p")
  done
  [ ${#clang_missing[@]} -eq 0 ] || apt_install "${clang_missing[@]}"
  CC=clang-14 CXX=clang++-14 build "$root/build-clang" -DCMAKE_BUILD_TYPE=Release -DBUILD_SHARED_LIBS=ON \
        -DCMAKE_C_FLAGS=-march=native -DCMAKE_CXX_FLAGS=-march=native -DSKELFORM_BUILD_BENCH=OFF
  echo "==> tests (clang, shared library, -march=native) (at $(since_start))"
  ctest --test-dir "$root/build-clang" --output-on-failure -j "$jobs" -E 'samples/viewer'
  # libFuzzer (clang, ASan + UBSan) on the asset loader, the baker's readers and the handle
  # files, each for SKELFORM_FUZZ_SECONDS (default 30) from seeds made from the data dir and
  # the procedural character; any finding fails (tests/fuzz/run.sh).
  echo "==> fuzzing (at $(since_start))"
  "$root/tests/fuzz/run.sh" "${SKELFORM_FUZZ_SECONDS:-30}"
  echo "==> every test stage passed (at $(since_start))"
}

run_main_job() {
  build "$root/build" -DCMAKE_BUILD_TYPE=Release
  mkdir -p "$root/out"
  local model=${1:-}
  if [ -z "$model" ]; then
    echo "==> generating the procedural test character, rigged and animated (walk, bend)"
    "$root/build/samples/skelform-character" -o "$root/out/character.glb"
    model="$root/out/character.glb"
  fi
  if [ ! -f "$model" ]; then
    echo "run.sh: error: $model: no such file" >&2
    exit 1
  fi
  local name extension
  name=$(basename "${model%.*}")
  extension=$(printf '%s' "${model##*.}" | tr '[:upper:]' '[:lower:]')
  echo "==> baking the skeletal mesh of $model"
  "$root/build/bake/skelform-bake" skeleton "$model" -o "$root/out/$name.skeleton.obj" \
      --voronoi-points "$root/out/$name.voronoi.obj" -v
  echo "==> wrote out/$name.skeleton.obj (skeletal mesh) and out/$name.voronoi.obj (inner Voronoi vertices)"
  if [ "$extension" != glb ] && [ "$extension" != gltf ]; then
    echo "==> $model is not a glTF: no skin or animation to play (give a skinned .glb or .gltf)"
    return 0
  fi
  echo "==> playing every animation of $model through skelform and LBS (baked first if needed)"
  "$root/build/samples/skelform-animate" "$model" -o "$root/out/$name.anim.glb"
  if command -v node >/dev/null 2>&1 && [ -d "$root/tools/node_modules/gltf-validator" ]; then
    node "$root/tools/validate-gltf.js" "$root/out/$name.anim.glb" | head -n 1
  fi
  echo "==> wrote out/$name.anim.glb: skelform (left) beside LBS (right) and the skeletal mesh, any glTF viewer plays it"
  echo "==> open it in the web viewer:"
  echo "    ./run.sh viewer out/$name.anim.glb"
}

# The web viewer (samples/viewer): three.js and playwright-core pinned in its package-lock.json.
install_viewer() {
  install_node
  if [ ! -d "$root/samples/viewer/node_modules/three" ] || [ ! -d "$root/samples/viewer/node_modules/playwright-core" ]; then
    echo "==> npm ci (samples/viewer: three.js, playwright-core)"
    (cd "$root/samples/viewer" && npm ci --no-audit --no-fund --loglevel=error)
  fi
}

# The README's quality table: skelform-quality over the whole corpus, as Markdown.
run_quality() {
  local data=${SKELFORM_DATA_DIR:-$root/../shared/data}
  [ -d "$data/quaternius" ] || { echo "run.sh quality: $data/quaternius not found (set SKELFORM_DATA_DIR)" >&2; exit 1; }
  build "$root/build" -DCMAKE_BUILD_TYPE=Release --target skelform-quality --target skelform-character
  mkdir -p "$root/out/procedural"
  "$root/build/samples/skelform-character" -o "$root/out/procedural/character.glb" >/dev/null
  local inputs=("$data/quaternius" "$root/out/procedural/character.glb") sample
  for sample in CesiumMan/CesiumMan.glb Fox/Fox.glb RiggedFigure/RiggedFigure.glb RiggedSimple/RiggedSimple.glb \
                SimpleSkin/SimpleSkin.gltf; do
    [ -f "$data/$sample" ] && inputs+=("$data/$sample")
  done
  echo "==> skelform-quality over ${#inputs[@]} inputs, 9 frames per animation"
  "$root/build/samples/skelform-quality" "${inputs[@]}" --frames 9 -q --markdown --check "$@"
}

# The README's speed table: skelform-bench over CesiumMan and its 75K-triangle refinement.
run_speed() {
  local runs=${1:-5}
  build "$root/build" -DCMAKE_BUILD_TYPE=Release --target skelform-bench
  echo "==> skelform-bench --markdown --runs $runs"
  "$root/build/bench/skelform-bench" --markdown --runs "$runs"
}

# docs/images/*.png: the README's pictures, from the viewer on skelform-animate's files.
run_screenshots() {
  install_viewer
  local data=${SKELFORM_DATA_DIR:-$root/../shared/data} model
  for model in CesiumMan/CesiumMan.glb Fox/Fox.glb quaternius/animals_pack/Horse.glb; do
    [ -f "$data/$model" ] || { echo "run.sh screenshots: $data/$model not found (set SKELFORM_DATA_DIR)" >&2; exit 1; }
  done
  build "$root/build" -DCMAKE_BUILD_TYPE=Release --target skelform-animate
  local work=$root/out/screenshots
  mkdir -p "$work"
  echo "==> skelform-animate CesiumMan, Fox"
  "$root/build/samples/skelform-animate" "$data/CesiumMan/CesiumMan.glb" -o "$work/CesiumMan.anim.glb"
  "$root/build/samples/skelform-animate" "$data/Fox/Fox.glb" -o "$work/Fox.anim.glb"
  "$root/build/samples/skelform-animate" "$data/quaternius/animals_pack/Horse.glb" -o "$work/Horse.anim.glb"
  echo "==> screenshots (headless chromium)"
  node "$root/samples/viewer/headless/screenshots.js" "$root/docs/images" \
       --cesium "$work/CesiumMan.anim.glb" --fox "$work/Fox.anim.glb" --gallop "$work/Horse.anim.glb"
}

case "${1:-}" in
  test|screenshots) apt_packages+=(chromium) ;;  # headless browser for the viewer's test and pictures
esac
install_missing_packages
case "${1:-}" in
  test) install_viewer; run_tests ;;
  viewer) shift; install_viewer; exec "$root/samples/viewer/serve.sh" "$@" ;;
  screenshots) run_screenshots ;;
  quality) shift; run_quality "$@" ;;
  speed) shift; run_speed "$@" ;;
  -h|--help) sed -n '2,33p' "$0" ;;
  *) run_main_job "${1:-}" ;;
esac
