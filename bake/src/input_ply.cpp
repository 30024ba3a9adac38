// PLY (ASCII, binary little- and big-endian): the `vertex` element's x/y/z and the `face`
// element's vertex_indices (or vertex_index) list; every other element and property is
// skipped by its declared layout, so any PLY a scanner or DCC tool writes loads.
#include "input_formats.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace skelform::bake::detail {
namespace {

enum class Scalar { int8, uint8, int16, uint16, int32, uint32, float32, float64, invalid };

Scalar scalar_of(std::string_view name) {
  if (name == "char" || name == "int8") return Scalar::int8;
  if (name == "uchar" || name == "uint8") return Scalar::uint8;
  if (name == "short" || name == "int16") return Scalar::int16;
  if (name == "ushort" || name == "uint16") return Scalar::uint16;
  if (name == "int" || name == "int32") return Scalar::int32;
  if (name == "uint" || name == "uint32") return Scalar::uint32;
  if (name == "float" || name == "float32") return Scalar::float32;
  if (name == "double" || name == "float64") return Scalar::float64;
  return Scalar::invalid;
}

size_t size_of(Scalar s) {
  switch (s) {
    case Scalar::int8:
    case Scalar::uint8:
      return 1;
    case Scalar::int16:
    case Scalar::uint16:
      return 2;
    case Scalar::int32:
    case Scalar::uint32:
    case Scalar::float32:
      return 4;
    case Scalar::float64:
      return 8;
    default:
      return 0;
  }
}

bool is_integer(Scalar s) { return s != Scalar::float32 && s != Scalar::float64; }

struct Property {
  std::string name;
  bool is_list = false;
  Scalar count_type = Scalar::invalid;  // lists only
  Scalar value_type = Scalar::invalid;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
};

enum class Encoding { ascii, binary_little_endian, binary_big_endian };

// The row being read, turned into text only when a message needs it.
struct Where {
  const std::string& element;
  uint64_t row;
  std::string text() const { return "element '" + element + "' " + std::to_string(row); }
};

// Reads body values one at a time in either encoding; `where` describes the current element
// for messages.
class BodyReader {
 public:
  BodyReader(const std::vector<unsigned char>& bytes, size_t offset, Encoding encoding, const std::string& name)
      : bytes_(bytes), offset_(offset), encoding_(encoding), name_(name) {}

  double value(Scalar type, const Where& where) {
    return encoding_ == Encoding::ascii ? ascii_value(type, where) : binary_value(type, where);
  }

  size_t remaining() const { return bytes_.size() - offset_; }
  Encoding encoding() const { return encoding_; }

 private:
  double ascii_value(Scalar type, const Where& where) {
    while (offset_ < bytes_.size() && (is_space(static_cast<char>(bytes_[offset_])) || bytes_[offset_] == '\n'))
      ++offset_;
    const size_t start = offset_;
    while (offset_ < bytes_.size() && !is_space(static_cast<char>(bytes_[offset_])) && bytes_[offset_] != '\n')
      ++offset_;
    const std::string_view token(reinterpret_cast<const char*>(bytes_.data()) + start, offset_ - start);
    if (token.empty()) throw Error(ErrorKind::invalid_input, name_ + ": file ends inside " + where.text());
    if (is_integer(type)) {
      int64_t v = 0;
      if (!parse_int(token, v))
        throw Error(ErrorKind::invalid_input, name_ + ": " + where.text() + ": bad integer " + quote_token(token));
      return static_cast<double>(v);
    }
    double v = 0;
    if (!parse_double(token, v))
      throw Error(ErrorKind::invalid_input, name_ + ": " + where.text() + ": bad number " + quote_token(token));
    return v;
  }

  double binary_value(Scalar type, const Where& where) {
    const size_t size = size_of(type);
    if (remaining() < size)
      throw Error(ErrorKind::invalid_input, name_ + ": truncated binary body: file ends inside " + where.text());
    unsigned char raw[8];
    for (size_t i = 0; i < size; ++i)
      raw[i] = bytes_[offset_ + (encoding_ == Encoding::binary_little_endian ? i : size - 1 - i)];
    offset_ += size;
    uint64_t bits = 0;
    for (size_t i = 0; i < size; ++i) bits |= uint64_t{raw[i]} << (8 * i);
    switch (type) {
      case Scalar::int8:
        return static_cast<int8_t>(bits);
      case Scalar::uint8:
        return static_cast<double>(bits);
      case Scalar::int16:
        return static_cast<int16_t>(bits);
      case Scalar::uint16:
        return static_cast<double>(bits);
      case Scalar::int32:
        return static_cast<int32_t>(bits);
      case Scalar::uint32:
        return static_cast<double>(bits);
      case Scalar::float32: {
        const uint32_t b32 = static_cast<uint32_t>(bits);
        float f;
        std::memcpy(&f, &b32, sizeof f);
        return f;
      }
      case Scalar::float64: {
        double d;
        std::memcpy(&d, &bits, sizeof d);
        return d;
      }
      default:
        return 0.0;
    }
  }

  const std::vector<unsigned char>& bytes_;
  size_t offset_;
  Encoding encoding_;
  const std::string& name_;
};

[[noreturn]] void fail(const std::string& name, const std::string& what) {
  throw Error(ErrorKind::invalid_input, name + ": " + what);
}

// Every row of an element with properties takes at least one byte of the body (binary) or
// two (ASCII: a value and a separator), so rows beyond the body's size in total are a lie,
// refused before any is read: counts checked per element alone would let many elements of
// large counts each pass, and reading them cost their sum.
void check_total_rows(const std::vector<Element>& elements, size_t body_bytes, const std::string& name) {
  uint64_t rows = 0;
  for (const Element& element : elements) {
    if (element.properties.empty()) continue;
    if (element.count > body_bytes - rows)
      fail(name, "element '" + element.name + "' declares " + std::to_string(element.count) + " rows, more than the " +
                     std::to_string(body_bytes - rows) + " bytes of the body left for it after the elements before it");
    rows += element.count;
  }
}

}  // namespace

InputMesh load_ply(const std::vector<unsigned char>& bytes, const std::string& name) {
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  LineScanner header(text);
  if (!header.next_line() || header.token() != "ply") fail(name, "not a PLY file (no 'ply' magic line)");

  Encoding encoding = Encoding::ascii;
  bool have_format = false;
  bool have_end = false;
  std::vector<Element> elements;
  size_t body_offset = 0;
  while (header.next_line()) {
    const std::string where = "header line " + std::to_string(header.line_number());
    const std::string_view keyword = header.token();
    if (keyword == "end_header") {
      have_end = true;
      body_offset = static_cast<size_t>(header.line().data() + header.line().size() - text.data());
      if (body_offset < text.size()) ++body_offset;  // the '\n' ending the header
      break;
    }
    if (keyword == "format") {
      const std::string_view format = header.token();
      if (format == "ascii")
        encoding = Encoding::ascii;
      else if (format == "binary_little_endian")
        encoding = Encoding::binary_little_endian;
      else if (format == "binary_big_endian")
        encoding = Encoding::binary_big_endian;
      else
        fail(name, where + ": unknown format " + quote_token(format));
      have_format = true;
    } else if (keyword == "element") {
      Element element;
      element.name = std::string(header.token());
      int64_t count = -1;
      const std::string_view count_token = header.token();
      if (element.name.empty() || !parse_int(count_token, count) || count < 0)
        fail(name, where + ": bad element declaration (expected 'element NAME COUNT')");
      element.count = static_cast<uint64_t>(count);
      elements.push_back(element);
    } else if (keyword == "property") {
      if (elements.empty()) fail(name, where + ": property before any element");
      Property property;
      const std::string_view type = header.token();
      if (type == "list") {
        property.is_list = true;
        property.count_type = scalar_of(header.token());
        property.value_type = scalar_of(header.token());
        if (property.count_type == Scalar::invalid || property.value_type == Scalar::invalid ||
            !is_integer(property.count_type))
          fail(name, where + ": bad list property (expected 'property list COUNT_TYPE VALUE_TYPE NAME')");
      } else {
        property.value_type = scalar_of(type);
        if (property.value_type == Scalar::invalid) fail(name, where + ": unknown property type " + quote_token(type));
      }
      property.name = std::string(header.token());
      if (property.name.empty()) fail(name, where + ": property without a name");
      elements.back().properties.push_back(property);
    } else if (keyword != "comment" && keyword != "obj_info" && !keyword.empty()) {
      fail(name, where + ": unknown header keyword " + quote_token(keyword));
    }
  }
  if (!have_end) fail(name, "truncated header (no end_header line)");
  if (!have_format) fail(name, "header has no format line");

  InputMesh mesh;
  std::vector<uint64_t> face_of_triangle;  // for out-of-range messages after all elements are read
  std::vector<uint32_t> polygon;
  bool have_faces = false;
  BodyReader reader(bytes, body_offset, encoding, name);
  check_total_rows(elements, reader.remaining(), name);
  for (const Element& element : elements) {
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    int xyz[3] = {-1, -1, -1};
    int face_list = -1;
    for (size_t p = 0; p < element.properties.size(); ++p) {
      const Property& property = element.properties[p];
      if (is_vertex && !property.is_list) {
        for (int axis = 0; axis < 3; ++axis)
          if (property.name == std::string(1, static_cast<char>('x' + axis))) xyz[axis] = static_cast<int>(p);
      }
      if (is_face && property.is_list && (property.name == "vertex_indices" || property.name == "vertex_index"))
        face_list = static_cast<int>(p);
    }
    if (is_vertex && (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0))
      fail(name, "element 'vertex' lacks an x, y or z property");
    if (is_face && face_list < 0) fail(name, "element 'face' has no vertex_indices list");
    if (is_face) have_faces = element.count > 0;
    // Rows without properties take no bytes and hold nothing: skipped whole, not counted out.
    if (element.properties.empty()) continue;
    if (is_vertex) {
      check_input_limits(mesh.positions.size() + static_cast<size_t>(element.count), mesh.triangles.size(), name);
      mesh.positions.reserve(mesh.positions.size() + static_cast<size_t>(element.count));
    }

    for (uint64_t row = 0; row < element.count; ++row) {
      const Where where{element.name, row};
      Vec3 position(0.0);
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        if (!property.is_list) {
          const double v = reader.value(property.value_type, where);
          for (int axis = 0; axis < 3; ++axis)
            if (is_vertex && xyz[axis] == static_cast<int>(p)) position[axis] = v;
          continue;
        }
        const double count_value = reader.value(property.count_type, where);
        if (count_value < 0 || count_value > static_cast<double>(reader.remaining()))
          fail(name,
               where.text() + ": list length " + std::to_string(static_cast<int64_t>(count_value)) + " is impossible");
        const size_t count = static_cast<size_t>(count_value);
        const bool wanted = is_face && face_list == static_cast<int>(p);
        if (wanted) polygon.clear();
        for (size_t i = 0; i < count; ++i) {
          const double v = reader.value(property.value_type, where);
          if (!wanted) continue;
          if (v < 0 || v != std::floor(v) || v > std::numeric_limits<uint32_t>::max())
            fail(name, where.text() + ": bad vertex index " + std::to_string(v));
          polygon.push_back(static_cast<uint32_t>(v));
        }
        if (wanted) {
          if (polygon.size() < 3)
            fail(name,
                 where.text() + ": face with " + std::to_string(polygon.size()) + " vertices (at least 3 needed)");
          append_fan(polygon, mesh.triangles, name);
          face_of_triangle.resize(mesh.triangles.size(), row);
        }
      }
      if (is_vertex) {
        if (!std::isfinite(position.x) || !std::isfinite(position.y) || !std::isfinite(position.z))
          fail(name, where.text() + ": non-finite coordinate");
        mesh.positions.push_back(position);
      }
    }
  }

  if (mesh.positions.empty()) fail(name, "no vertices (no 'vertex' element with rows)");
  if (!have_faces) fail(name, "no faces (no 'face' element with rows)");
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    for (uint32_t v : mesh.triangles[t])
      if (v >= mesh.positions.size())
        fail(name, "element 'face' " + std::to_string(face_of_triangle[t]) + ": vertex index " + std::to_string(v) +
                       " out of range (" + std::to_string(mesh.positions.size()) + " vertices)");

  add_whole_primitive(mesh, mesh.positions.size());
  return mesh;
}

}  // namespace skelform::bake::detail
