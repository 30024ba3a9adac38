// tinygltf's implementation, compiled with the fuzzers' instrumentation (CMakeLists.txt says
// why). stb comes from libstb (the runtime and the baker skip images anyway), so neither
// STB_*_IMPLEMENTATION nor TINYGLTF_NO_STB_* is defined: the header's inline parts then
// match those the runtime's and the baker's files were compiled with.
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
