// Internal to core/io: what the PLY reader and writer share. The scalar types, the header (its
// format line and the table of elements and their properties, as ParsePlyHeader reads it) and
// the reader of the values in the body, ASCII or binary of either byte order.
#pragma once

#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/formats.h"

namespace meshsmooth::io {

enum class PlyType { kI8, kU8, kI16, kU16, kI32, kU32, kF32, kF64 };

// The type a header names, by either of its names ("uchar" or "uint8"); false for any other.
bool PlyTypeFromName(std::string_view name, PlyType& t);

// The name written for the type ("uchar", "float", ...).
std::string_view PlyTypeName(PlyType t);

// Bytes of a binary value of the type.
inline size_t PlyTypeSize(PlyType t) {
  switch (t) {
    case PlyType::kI8:
    case PlyType::kU8:
      return 1;
    case PlyType::kI16:
    case PlyType::kU16:
      return 2;
    case PlyType::kI32:
    case PlyType::kU32:
    case PlyType::kF32:
      return 4;
    case PlyType::kF64:
      return 8;
  }
  return 1;
}

struct PlyProperty {
  std::string_view name;  // never empty
  PlyType type = PlyType::kF32;
  bool is_list = false;
  PlyType count_type = PlyType::kU8;  // of a list's length
};

// An element of the header and its property table: a row of the body holds the properties'
// values in this order.
struct PlyElement {
  std::string_view name;
  int64_t count = 0;  // rows, 0 .. INT32_MAX
  std::vector<PlyProperty> props;

  // The index in `props` of the first property named `name`, or -1.
  int Find(std::string_view name) const;
  // The same for a scalar property: -1 also when the first property of that name is a list.
  int FindScalar(std::string_view name) const;
};

enum class PlyEncoding { kAscii, kLittle, kBig };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::kAscii;
  std::vector<PlyElement> elements;  // in the order the body holds them
  size_t body_offset = 0;            // where the body starts in the data

  // The element named "vertex" (a header has at most one), or null.
  const PlyElement* vertex() const;
};

// InvalidArgument "PLY: `what`", the form of every error of the reader.
absl::Status PlyError(std::string_view what);

// Reads the header of a PLY file: the `ply` line, then `format`, `element`, `property`,
// `comment` and `obj_info` lines (blank lines are passed over) up to `end_header`. The names
// in the result point into `data`. InvalidArgument (PlyError) naming what is wrong: no `ply`
// line, an unknown format or type, an element count that is not 0 .. INT32_MAX, a second
// vertex element, a property before any element or without a name, any other line, or no
// format or end_header line.
absl::StatusOr<PlyHeader> ParsePlyHeader(std::string_view data);

// Reads the values of the body one at a time, in the header's encoding; Read() is false when
// the data runs out or a token is not a number.
class PlyValueReader {
 public:
  PlyValueReader(std::string_view body, PlyEncoding enc) : body_(body), enc_(enc) {}

  [[gnu::always_inline]] bool Read(PlyType t, double& out) {
    if (enc_ == PlyEncoding::kAscii) {
      if (t != PlyType::kF32) return ParseDouble(NextToken(body_), out);
      // A declared float is rounded from the text to float, as a binary file would hold it.
      std::string_view tok = NextToken(body_);
      if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
      float f = 0.0f;
      auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), f);
      out = f;
      return ec == std::errc() && ptr == tok.data() + tok.size();
    }
    const size_t n = PlyTypeSize(t);
    if (pos_ + n > body_.size()) return false;
    unsigned char b[8];
    std::memcpy(b, body_.data() + pos_, n);
    pos_ += n;
    if ((enc_ == PlyEncoding::kBig) == (std::endian::native == std::endian::little)) {
      for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    }
    switch (t) {
      case PlyType::kI8:
        out = static_cast<int8_t>(b[0]);
        break;
      case PlyType::kU8:
        out = b[0];
        break;
      case PlyType::kI16:
        out = Load<int16_t>(b);
        break;
      case PlyType::kU16:
        out = Load<uint16_t>(b);
        break;
      case PlyType::kI32:
        out = Load<int32_t>(b);
        break;
      case PlyType::kU32:
        out = Load<uint32_t>(b);
        break;
      case PlyType::kF32:
        out = Load<float>(b);
        break;
      case PlyType::kF64:
        out = Load<double>(b);
        break;
    }
    return true;
  }
  // Bytes (ASCII: characters) not read yet.
  size_t remaining() const { return enc_ == PlyEncoding::kAscii ? body_.size() : body_.size() - pos_; }

 private:
  template <typename T>
  static T Load(const unsigned char* b) {
    T v;
    std::memcpy(&v, b, sizeof v);
    return v;
  }
  std::string_view body_;
  PlyEncoding enc_;
  size_t pos_ = 0;
};

}  // namespace meshsmooth::io
