// Bake step 8: the baked glTF, i.e. the input glTF unchanged plus the
// SKELFORM_skeletal_deformation extension (docs/SKELFORM_skeletal_deformation.md).
//
// The input's JSON is edited, never re-serialised from a model: every existing member keeps
// its value, new bufferViews and accessors are appended after the existing ones (existing
// indices stay valid), the extension's arrays are appended to buffer 0, the extension object
// goes into the root `extensions` and its name into `extensionsUsed` (never into
// `extensionsRequired`, so other viewers still show the ordinarily skinned model).
// The output depends only on the inputs: the same input always gives the same bytes.
#pragma once

#include "skelform/bake/baked.h"

#include <string>
#include <vector>

namespace skelform::bake {

// Writes `input_path` (.gltf or .glb) plus the extension describing `deformables` to
// `output_path`. The container follows the output's extension (case-insensitive):
//   .glb   everything of buffer 0 (BIN chunk, data URI or external file) goes into the BIN
//          chunk, followed by the extension arrays;
//   .gltf  buffer 0 stays a base64 data URI when it was one in the input; otherwise it is
//          written beside the output as OUTPUT_STEM.bin (e.g. out/a.skf.gltf -> out/a.skf.bin).
// Other external files the input references by relative URI (buffers 1..n, images) are
// copied to the same relative path under the output's directory when that differs from the
// input's, so the output resolves them from where it is; a relative URI leaving the input's
// directory ("../x.png") is rewritten relative to the output's directory instead. URIs of
// missing files are kept as they are (the output is then exactly as broken as the input).
//
// Each file is written atomically (output.h): the .bin first, then copied resources, then
// the document, so an existing output is replaced only when everything before it succeeded.
// The input file and files it references are never overwritten.
//
// Throws Error(ErrorKind::usage) when the output would overwrite the input (or a file it
// references) or has neither extension, Error(ErrorKind::io) when a file cannot be read or
// written, Error(ErrorKind::invalid_input) for malformed input (truncated GLB, bad chunk
// lengths, JSON that is not a glTF object, a buffer shorter than its byteLength, bad base64),
// Error(ErrorKind::unsupported) for a buffer 0 the writer cannot carry (non-base64 data
// URI, remote URL), and std::invalid_argument when a deformable's arrays do not have the
// shapes extension_layout.h requires or refer to a mesh/node/skin/primitive that the input
// lacks (a baker bug, not bad input).
void write_baked_gltf(const std::string& input_path, const std::vector<BakedDeformable>& deformables,
                      const std::string& output_path);

// In-memory variant: `input` holds a whole .glb or .gltf file; external buffers it names
// are read relative to `resource_dir`. Returns the bytes of the baked GLB (buffer 0 in the
// BIN chunk, other URIs unchanged). Same errors as write_baked_gltf, without file output.
std::string baked_glb(const std::string& input, const std::string& resource_dir,
                      const std::vector<BakedDeformable>& deformables);

}  // namespace skelform::bake
