/* Minimal GLB skin reader: see glb_skin.h for what it reads and why. */
#include "glb_skin.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- JSON, navigated in place on a NUL-terminated copy of the JSON chunk (no tree) ---- */

static const char* json_ws(const char* p) {
  while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') ++p;
  return p;
}

/* p at an opening quote: returns what follows the closing quote, or NULL. */
static const char* json_skip_string(const char* p) {
  for (++p; *p != '"'; ++p) {
    if (*p == '\0') return NULL;
    if (*p == '\\' && *++p == '\0') return NULL;
  }
  return p + 1;
}

/* Skips one value (string, number, literal, object, array); returns what follows, or NULL. */
static const char* json_skip(const char* p) {
  int depth = 0;
  p = json_ws(p);
  do {
    if (*p == '"') {
      if (!(p = json_skip_string(p))) return NULL;
    } else if (*p == '{' || *p == '[') {
      ++depth, ++p;
    } else if (*p == '}' || *p == ']') {
      if (--depth < 0) return NULL;
      ++p;
    } else if (*p == '\0') {
      return NULL;
    } else if (depth == 0) { /* a number or literal on its own */
      size_t n = strcspn(p, ",}] \t\r\n");
      if (n == 0) return NULL;
      p += n;
    } else {
      ++p; /* inside a container: numbers, literals, ':' and ',' */
    }
  } while (depth > 0);
  return p;
}

/* The value of member `key` of the object at p, or NULL (absent, or p not an object). */
static const char* json_member(const char* p, const char* key) {
  const size_t key_length = strlen(key);
  if (!p || *(p = json_ws(p)) != '{') return NULL;
  p = json_ws(p + 1);
  while (*p == '"') {
    const char* name = p + 1;
    const char* after_name = json_skip_string(p);
    if (!after_name || *(p = json_ws(after_name)) != ':') return NULL;
    p = json_ws(p + 1);
    if ((size_t)(after_name - 1 - name) == key_length && memcmp(name, key, key_length) == 0) return p;
    if (!(p = json_skip(p)) || *(p = json_ws(p)) != ',') return NULL;
    p = json_ws(p + 1);
  }
  return NULL;
}

/* Element `index` of the array at p, or NULL. */
static const char* json_element(const char* p, long index) {
  long i;
  if (!p || *(p = json_ws(p)) != '[') return NULL;
  p = json_ws(p + 1);
  if (*p == ']') return NULL;
  for (i = 0; i < index; ++i) {
    if (!(p = json_skip(p)) || *(p = json_ws(p)) != ',') return NULL;
    p = json_ws(p + 1);
  }
  return p;
}

static long json_length(const char* array) {
  long n = 0;
  while (json_element(array, n)) ++n;
  return n;
}

/* A non-negative integer: `absent` when p is NULL, -1 when p is not one. */
static long json_index(const char* p, long absent) {
  char* end;
  long value;
  if (!p) return absent;
  value = strtol(p, &end, 10);
  return end == p || value < 0 ? -1 : value;
}

static int json_string_is(const char* p, const char* text) {
  const size_t n = strlen(text);
  return p && *p == '"' && strncmp(p + 1, text, n) == 0 && p[n + 1] == '"';
}

/* ---- GLB container and the skin ---- */

static uint32_t le32(const unsigned char* p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Decodes base64 text (up to its closing quote) into `out`, at most `capacity` bytes;
 * returns the number of bytes decoded. */
static size_t base64_decode(const char* text, unsigned char* out, size_t capacity) {
  static const char alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  unsigned long bits = 0;
  int bit_count = 0;
  size_t n = 0;
  const char* digit;
  for (; *text && *text != '"' && *text != '=' && n < capacity; ++text) {
    if (!(digit = strchr(alphabet, *text))) return n;
    bits = (bits << 6 | (unsigned long)(digit - alphabet)) & 0xFFFFFFu;
    if ((bit_count += 6) >= 8) out[n++] = (unsigned char)(bits >> (bit_count -= 8));
  }
  return n;
}

static void* alloc_array(const sf_allocator* allocator, size_t count, size_t size) {
  if (count == 0) count = 1;
  if (count > (size_t)-1 / size) return NULL;
  return allocator->alloc(allocator->user, count * size, 16);
}

void glb_skin_free(glb_skin* skin, const sf_allocator* allocator) {
  allocator->free(allocator->user, skin->parent);
  allocator->free(allocator->user, skin->order);
  allocator->free(allocator->user, skin->inverse_bind);
  memset(skin, 0, sizeof *skin);
}

#define FAIL(...)                                 \
  do {                                            \
    snprintf(error, error_capacity, __VA_ARGS__); \
    goto fail;                                    \
  } while (0)

int glb_skin_read(const unsigned char* data, size_t size, int32_t skin_index, const sf_allocator* allocator,
                  glb_skin* out, char* error, size_t error_capacity) {
  char* json = NULL;
  unsigned char* decoded = NULL; /* a buffer given as a base64 data URI (.gltf input kept it) */
  long* joint_node = NULL;       /* node of each joint; reused as each joint's depth for `order` */
  const unsigned char* bin = NULL;
  size_t bin_size = 0, json_size;
  const char *skin, *joints, *nodes, *ibm;
  long n, i, k, c, depth, max_depth = 0;

  memset(out, 0, sizeof *out);
  if (size < 20 || le32(data) != 0x46546C67u || le32(data + 4) != 2) FAIL("not a glTF 2.0 binary (.glb)");
  json_size = le32(data + 12);
  if (le32(data + 16) != 0x4E4F534Au || json_size > size - 20) FAIL("GLB: no JSON chunk");
  if (size - 20 - json_size >= 8 && le32(data + 20 + json_size + 4) == 0x004E4942u) {
    bin_size = le32(data + 20 + json_size);
    bin = data + 28 + json_size;
    if (bin_size > size - 28 - json_size) FAIL("GLB: BIN chunk truncated");
  }
  if (!(json = alloc_array(allocator, json_size + 1, 1))) FAIL("out of memory");
  memcpy(json, data + 20, json_size);
  json[json_size] = '\0';

  skin = json_element(json_member(json, "skins"), skin_index);
  joints = json_member(skin, "joints");
  if (!skin || (n = json_length(joints)) == 0) FAIL("skin %ld has no joints", (long)skin_index);
  out->joint_count = (uint32_t)n;
  out->parent = alloc_array(allocator, (size_t)n, sizeof *out->parent);
  out->order = alloc_array(allocator, (size_t)n, sizeof *out->order);
  out->inverse_bind = alloc_array(allocator, (size_t)n * 16, sizeof *out->inverse_bind);
  joint_node = alloc_array(allocator, (size_t)n, sizeof *joint_node);
  if (!out->parent || !out->order || !out->inverse_bind || !joint_node) FAIL("out of memory");

  /* Parents: joint k is the parent of joint i when node joints[i] is a child of node joints[k]. */
  nodes = json_member(json, "nodes");
  for (i = 0; i < n; ++i) {
    out->parent[i] = -1;
    if ((joint_node[i] = json_index(json_element(joints, i), -1)) < 0) FAIL("skin joint %ld: bad node index", i);
  }
  for (k = 0; k < n; ++k) {
    const char* children = json_member(json_element(nodes, joint_node[k]), "children");
    const char* child;
    for (c = 0; (child = json_element(children, c)) != NULL; ++c)
      for (i = 0; i < n; ++i)
        if (joint_node[i] == json_index(child, -2)) out->parent[i] = (int32_t)k;
  }
  /* Parent-first order: sort by depth in the hierarchy (a cycle would be invalid glTF). */
  for (i = 0; i < n; ++i) {
    for (depth = 0, k = out->parent[i]; k >= 0; k = out->parent[k])
      if (++depth > n) FAIL("skin %ld: the joint hierarchy has a cycle", (long)skin_index);
    joint_node[i] = depth;
    if (depth > max_depth) max_depth = depth;
  }
  for (k = 0, depth = 0; depth <= max_depth; ++depth)
    for (i = 0; i < n; ++i)
      if (joint_node[i] == depth) out->order[k++] = (uint32_t)i;

  /* inverseBindMatrices: a float MAT4 accessor into the BIN chunk (absent: identities). */
  ibm = json_member(skin, "inverseBindMatrices");
  if (!ibm) {
    for (i = 0; i < n * 16; ++i) out->inverse_bind[i] = i % 16 % 5 == 0 ? 1.0f : 0.0f;
  } else {
    const char* accessor = json_element(json_member(json, "accessors"), json_index(ibm, -1));
    const char* view =
        json_element(json_member(json, "bufferViews"), json_index(json_member(accessor, "bufferView"), -1));
    const long accessor_offset = json_index(json_member(accessor, "byteOffset"), 0);
    const long view_offset = json_index(json_member(view, "byteOffset"), 0);
    const long view_length = json_index(json_member(view, "byteLength"), -1);
    const long stride = json_index(json_member(view, "byteStride"), 64);
    const long buffer_index = json_index(json_member(view, "buffer"), -1);
    const char* buffer = json_element(json_member(json, "buffers"), buffer_index);
    const char* uri = json_member(buffer, "uri");
    const unsigned char* bytes = bin;
    size_t byte_count = bin_size;
    if (!accessor || json_index(json_member(accessor, "componentType"), -1) != 5126 ||
        !json_string_is(json_member(accessor, "type"), "MAT4") || json_index(json_member(accessor, "count"), -1) < n)
      FAIL("inverseBindMatrices: not %ld float MAT4", n);
    if (uri) { /* not the BIN chunk: only a base64 data URI is read, not external files */
      const char* base64 = strstr(uri, ";base64,");
      const long length = json_index(json_member(buffer, "byteLength"), -1);
      if (strncmp(uri, "\"data:", 6) != 0 || !base64 || base64 > json_skip_string(uri) || length <= 0)
        FAIL("inverseBindMatrices: buffer %ld is an external file; this reader takes the BIN chunk or data URIs",
             buffer_index);
      if (!(decoded = alloc_array(allocator, (size_t)length, 1))) FAIL("out of memory");
      byte_count = base64_decode(base64 + 8, decoded, (size_t)length);
      bytes = decoded;
    } else if (buffer_index != 0) {
      bytes = NULL;
    }
    if (!view || !bytes || accessor_offset < 0 || view_offset < 0 || view_length < 0 || stride < 64 ||
        stride > view_length || (size_t)view_offset + (size_t)view_length > byte_count ||
        (size_t)accessor_offset + (size_t)(n - 1) * (size_t)stride + 64 > (size_t)view_length)
      FAIL("inverseBindMatrices: not inside buffer %ld", buffer_index);
    /* glTF is little-endian, like every platform this example targets. */
    for (i = 0; i < n; ++i) memcpy(out->inverse_bind + 16 * i, bytes + view_offset + accessor_offset + i * stride, 64);
  }
  allocator->free(allocator->user, decoded);
  allocator->free(allocator->user, joint_node);
  allocator->free(allocator->user, json);
  return 1;

fail:
  allocator->free(allocator->user, decoded);
  allocator->free(allocator->user, joint_node);
  allocator->free(allocator->user, json);
  glb_skin_free(out, allocator);
  return 0;
}
