#!/usr/bin/env bash
# Seed corpora for the fuzzers, written under OUT_DIR (never into the repository):
#
#   tests/fuzz/make_seeds.sh OUT_DIR
#
#   OUT_DIR/fuzz_asset/       baked assets: the tests' procedural capsule (also as a .gltf with
#                             a data-URI buffer), the project's procedural character and the
#                             small skinned models of the data directory; two unbaked glTFs
#   OUT_DIR/fuzz_bake_input/  one selector byte (0 .glb, 1 .gltf, 2 .obj, 3 .ply, 4 .off)
#                             followed by the file: glTF models, OBJ files, the same mesh as
#                             ASCII/binary PLY and OFF, and a few small hand-written files
#   OUT_DIR/fuzz_handles/     handle files (docs/handles-json.md) for the capsule
#
# Tools come from the fuzz build (tests/fuzz/run.sh builds them): override with SKELFORM_BAKE,
# SKELFORM_CHARACTER, SKELFORM_CAPSULE, or the directory with SKELFORM_FUZZ_BUILD_DIR. Models
# come from SKELFORM_DATA_DIR (default ../shared/data next to the repository); what is missing
# is skipped with a message. Seeds larger than 2 MB are dropped (slow to mutate).
set -euo pipefail

if [ $# -ne 1 ]; then
  echo "usage: $0 OUT_DIR" >&2
  exit 1
fi
out=$1
root=$(cd "$(dirname "$0")/../.." && pwd)
data=${SKELFORM_DATA_DIR:-$root/../shared/data}
build=${SKELFORM_FUZZ_BUILD_DIR:-$root/build-fuzz}
bake=${SKELFORM_BAKE:-$build/bake/skelform-bake}
character=${SKELFORM_CHARACTER:-$build/samples/skelform-character}
capsule=${SKELFORM_CAPSULE:-$build/tests/skelform_c_engine_capsule}
max_bytes=$((2 * 1024 * 1024))
# Only the tools' own failures matter here; their leaks are not what the seeds are for.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}

mkdir -p "$out/fuzz_asset" "$out/fuzz_bake_input" "$out/fuzz_handles"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

note() { echo "make_seeds: $*" >&2; }
have() { [ -x "$1" ] || { note "skipping: $1 not built"; return 1; }; }
size_of() { stat -c %s "$1"; }

# keep FILE DEST: copies FILE to DEST unless it is too large.
keep() {
  if [ "$(size_of "$1")" -gt "$max_bytes" ]; then
    note "skipping $(basename "$1"): larger than 2 MB"
    return 0
  fi
  cat "$1" > "$2"  # not cp: the data directory's files may be read-only
}

# selector BYTE FILE NAME: a fuzz_bake_input seed, BYTE then the file.
selector() {
  [ "$(size_of "$2")" -le "$max_bytes" ] || { note "skipping $(basename "$2"): larger than 2 MB"; return 0; }
  { printf "\\$(printf '%03o' "$1")"; cat "$2"; } > "$out/fuzz_bake_input/$3"
}

# bake_seed IN NAME: the baked IN (small control mesh, so the seed evaluates quickly).
bake_seed() {
  if "$bake" "$1" -o "$work/$2.skf.glb" --target-triangles 300 --quiet > "$work/bake.log" 2>&1; then
    keep "$work/$2.skf.glb" "$out/fuzz_asset/$2.skf.glb"
  else
    note "skelform-bake failed on $1: $(tail -n 1 "$work/bake.log")"
  fi
}

# GLB <-> .gltf with its buffer as a data URI, and OBJ -> PLY/OFF: small python helpers.
convert() {
  python3 - "$@" <<'PY'
import base64, json, struct, sys
mode, src, dst = sys.argv[1:4]
def obj_mesh(path):
    vs, fs = [], []
    for line in open(path, errors="replace"):
        p = line.split()
        if p and p[0] == "v": vs.append(tuple(float(x) for x in p[1:4]))
        elif p and p[0] == "f":
            idx = [int(x.split("/")[0]) for x in p[1:]]
            fs.append([i - 1 if i > 0 else len(vs) + i for i in idx])
    return vs, fs
if mode == "gltf":
    b = open(src, "rb").read()
    length = struct.unpack_from("<I", b, 8)[0]
    pos, doc, binary = 12, None, b""
    while pos < length:
        n, kind = struct.unpack_from("<II", b, pos)
        chunk = b[pos + 8:pos + 8 + n]
        if kind == 0x4E4F534A: doc = json.loads(chunk)
        elif kind == 0x004E4942: binary = chunk
        pos += 8 + n
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(binary).decode()
    open(dst, "w").write(json.dumps(doc))
else:
    vs, fs = obj_mesh(src)
    if mode == "off":
        with open(dst, "w") as f:
            f.write("OFF\n%d %d 0\n" % (len(vs), len(fs)))
            for v in vs: f.write("%g %g %g\n" % v)
            for face in fs: f.write("%d %s\n" % (len(face), " ".join(map(str, face))))
    else:
        fmt = {"ply_ascii": "ascii", "ply_le": "binary_little_endian", "ply_be": "binary_big_endian"}[mode]
        head = ("ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
                "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (fmt, len(vs), len(fs)))
        with open(dst, "wb") as f:
            f.write(head.encode())
            if fmt == "ascii":
                for v in vs: f.write(("%g %g %g\n" % v).encode())
                for face in fs: f.write(("%d %s\n" % (len(face), " ".join(map(str, face)))).encode())
            else:
                e = "<" if fmt == "binary_little_endian" else ">"
                for v in vs: f.write(struct.pack(e + "3f", *v))
                for face in fs: f.write(struct.pack(e + "B%di" % len(face), len(face), *face))
PY
}

# --- the tests' procedural capsule (tests/capsule_glb.h) ---
if have "$capsule"; then
  "$capsule" "$work/capsule.glb"
  selector 0 "$work/capsule.glb" capsule.glb
  convert gltf "$work/capsule.glb" "$work/capsule.gltf"
  selector 1 "$work/capsule.gltf" capsule.gltf
  if have "$bake"; then
    bake_seed "$work/capsule.glb" capsule
    [ -f "$work/capsule.skf.glb" ] && convert gltf "$work/capsule.skf.glb" "$out/fuzz_asset/capsule.skf.gltf"
  fi
fi

# --- the project's procedural character (samples/character), coarse so that it stays small ---
if have "$character"; then
  # The coarsest resolution it takes (height / 45).
  if "$character" -o "$work/character.glb" --resolution 0.04 > /dev/null &&
     "$character" -o "$work/character.obj" --resolution 0.04 > /dev/null; then
    selector 0 "$work/character.glb" character.glb
    selector 2 "$work/character.obj" character.obj
    have "$bake" && bake_seed "$work/character.glb" character
  else
    note "skelform-character failed: no character seeds"
  fi
fi

# --- third-party models of the data directory (read in place, never copied into the repo) ---
if [ -d "$data" ]; then
  for model in SimpleSkin/SimpleSkin.gltf RiggedSimple/RiggedSimple.glb RiggedFigure/RiggedFigure.glb \
               quaternius/fish_pack/Dolphin.glb quaternius/fish_pack/Fish1.glb Fox/Fox.glb CesiumMan/CesiumMan.glb; do
    [ -f "$data/$model" ] || { note "skipping $model: not in $data"; continue; }
    name=$(basename "$model")
    case $name in *.glb) byte=0 ;; *) byte=1 ;; esac
    # Large files mutate slowly: the baker's readers get the ones below 200 KB.
    [ "$(size_of "$data/$model")" -le 204800 ] && selector "$byte" "$data/$model" "$name"
    have "$bake" && bake_seed "$data/$model" "${name%.*}"
  done
  # Unbaked glTF: the runtime's "no extension" paths.
  for model in SimpleSkin/SimpleSkin.gltf RiggedSimple/RiggedSimple.glb; do
    [ -f "$data/$model" ] && keep "$data/$model" "$out/fuzz_asset/unbaked-$(basename "$model")"
  done
  if [ -f "$data/hand/hand_lowres.obj" ]; then
    selector 2 "$data/hand/hand_lowres.obj" hand_lowres.obj
    for mode in ply_ascii ply_le ply_be off; do
      convert "$mode" "$data/hand/hand_lowres.obj" "$work/hand.$mode"
      case $mode in off) byte=4 ;; *) byte=3 ;; esac
      selector "$byte" "$work/hand.$mode" "hand_lowres.$mode"
    done
  fi
else
  note "skipping third-party models: $data not found (set SKELFORM_DATA_DIR)"
fi

# --- small hand-written files: the syntax the readers accept, in a few bytes each ---
cat > "$work/tetra.obj" <<'END_OBJ'
# tetrahedron: vertex, texture and normal indices, a negative (relative) index, a quad
o tetra
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
vt 0 0
vn 0 0 1
f 1/1/1 3/1/1 2/1/1
f 1//1 2//1 4//1
f -4 4 3
g rest
f 2 3 4 2
END_OBJ
selector 2 "$work/tetra.obj" tetra.obj
cat > "$work/tetra.off" <<'END_OFF'
OFF
# comment
4 4 6
0 0 0
1 0 0
0 1 0
0 0 1
3 0 2 1
3 0 1 3
3 0 3 2
4 1 2 3 1
END_OFF
selector 4 "$work/tetra.off" tetra.off
cat > "$work/tetra.ply" <<'END_PLY'
ply
format ascii 1.0
comment tetrahedron with an extra property and element
element vertex 4
property double x
property double y
property double z
property uchar red
element face 4
property list uchar uint vertex_indices
element edge 0
property int vertex1
end_header
0 0 0 255
1 0 0 0
0 1 0 0
0 0 1 0
3 0 2 1
3 0 1 3
3 0 3 2
3 1 2 3
END_PLY
selector 3 "$work/tetra.ply" tetra.ply

# --- handle files for the capsule (z from -0.75 to 0.75, sphere above; ~500 vertices) ---
printf '%s\n' '{"handles": [{"vertex": 0, "target": [0.0, 0.0, -0.9]}]}' > "$out/fuzz_handles/one.json"
printf '%s\n' '{"handles": [{"vertex": 10, "target": [0.1, 0.2, 0.3]}, {"vertex": 200, "target": [0.4, 0.0, 1.0]}],
  "pinned": [1, 2, 3]}' > "$out/fuzz_handles/two_pinned.json"
printf '%s\n' '{"pinned": [], "handles": [{"vertex": 300, "target": [-1e3, 2.5e-3, 7]}]}' > "$out/fuzz_handles/far.json"
printf '%s\n' '{"handles": [{"vertex": 5, "target": [0, 0, 0]}], "pinned": [5]}' > "$out/fuzz_handles/pin_on_handle.json"

for target in fuzz_asset fuzz_bake_input fuzz_handles; do
  echo "make_seeds: $target: $(find "$out/$target" -type f | wc -l) seeds, $(du -sk "$out/$target" | cut -f1) KB"
done
