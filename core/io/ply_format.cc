#include "core/io/ply_format.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace meshsmooth::io {
namespace {

// `format ascii|binary_little_endian|binary_big_endian 1.0`; the version is not read.
absl::Status ReadFormatLine(std::string_view rest, PlyEncoding& enc) {
  const std::string_view f = NextToken(rest);
  if (f == "ascii") {
    enc = PlyEncoding::kAscii;
  } else if (f == "binary_little_endian") {
    enc = PlyEncoding::kLittle;
  } else if (f == "binary_big_endian") {
    enc = PlyEncoding::kBig;
  } else {
    return PlyError(absl::StrCat("unknown format '", Sv(f), "'"));
  }
  return absl::OkStatus();
}

// `element NAME COUNT`.
absl::Status ReadElementLine(std::string_view rest, std::vector<PlyElement>& elements) {
  PlyElement e;
  e.name = NextToken(rest);
  if (!ParseInt(NextToken(rest), e.count) || e.count < 0 || e.count > INT32_MAX) {
    return PlyError(absl::StrCat("bad count for element '", Sv(e.name), "'"));
  }
  // A second one would replace the positions and leave the first one's colours behind.
  if (e.name == "vertex" &&
      std::any_of(elements.begin(), elements.end(), [](const PlyElement& other) { return other.name == "vertex"; })) {
    return PlyError("more than one vertex element");
  }
  elements.push_back(std::move(e));
  return absl::OkStatus();
}

// `property TYPE NAME` or `property list COUNT_TYPE TYPE NAME`, of the last element.
absl::Status ReadPropertyLine(std::string_view rest, std::vector<PlyElement>& elements) {
  if (elements.empty()) return PlyError("a property before any element");
  PlyProperty p;
  std::string_view type = NextToken(rest);
  if (type == "list") {
    p.is_list = true;
    if (!PlyTypeFromName(NextToken(rest), p.count_type)) return PlyError("bad list count type");
    type = NextToken(rest);
  }
  if (!PlyTypeFromName(type, p.type)) return PlyError(absl::StrCat("unknown property type '", Sv(type), "'"));
  p.name = NextToken(rest);
  // A nameless property could not be written back, nor named in a Draco file's metadata,
  // whose entries cannot be empty.
  if (p.name.empty()) return PlyError(absl::StrCat("a ", Sv(type), " property without a name"));
  elements.back().props.push_back(p);
  return absl::OkStatus();
}

}  // namespace

bool PlyTypeFromName(std::string_view name, PlyType& t) {
  static constexpr std::pair<std::string_view, PlyType> kNames[] = {
      {"char", PlyType::kI8},   {"int8", PlyType::kI8},     {"uchar", PlyType::kU8},   {"uint8", PlyType::kU8},
      {"short", PlyType::kI16}, {"int16", PlyType::kI16},   {"ushort", PlyType::kU16}, {"uint16", PlyType::kU16},
      {"int", PlyType::kI32},   {"int32", PlyType::kI32},   {"uint", PlyType::kU32},   {"uint32", PlyType::kU32},
      {"float", PlyType::kF32}, {"float32", PlyType::kF32}, {"double", PlyType::kF64}, {"float64", PlyType::kF64}};
  for (const auto& [n, type] : kNames) {
    if (n == name) {
      t = type;
      return true;
    }
  }
  return false;
}

std::string_view PlyTypeName(PlyType t) {
  static constexpr std::string_view kNames[] = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double"};
  return kNames[static_cast<int>(t)];
}

int PlyElement::Find(std::string_view property) const {
  for (size_t i = 0; i < props.size(); ++i) {
    if (props[i].name == property) return static_cast<int>(i);
  }
  return -1;
}

int PlyElement::FindScalar(std::string_view property) const {
  const int i = Find(property);
  return i >= 0 && !props[i].is_list ? i : -1;
}

const PlyElement* PlyHeader::vertex() const {
  for (const PlyElement& e : elements) {
    if (e.name == "vertex") return &e;
  }
  return nullptr;
}

absl::Status PlyError(std::string_view what) { return absl::InvalidArgumentError(absl::StrCat("PLY: ", Sv(what))); }

absl::StatusOr<PlyHeader> ParsePlyHeader(std::string_view data) {
  LineReader lines(data);
  std::string_view line;
  if (!lines.Next(line) || line != "ply") return PlyError("missing the 'ply' magic line");
  PlyHeader header;
  bool have_format = false, have_end = false;
  while (lines.Next(line)) {
    std::string_view rest = line;
    const std::string_view key = NextToken(rest);
    absl::Status s;
    if (key == "format") {
      s = ReadFormatLine(rest, header.encoding);
      have_format = true;
    } else if (key == "element") {
      s = ReadElementLine(rest, header.elements);
    } else if (key == "property") {
      s = ReadPropertyLine(rest, header.elements);
    } else if (key == "end_header") {
      have_end = true;
      break;
    } else if (key != "comment" && key != "obj_info" && !key.empty()) {
      s = PlyError(absl::StrCat("unexpected header line '", Sv(line), "'"));
    }
    if (!s.ok()) return s;
  }
  if (!have_format || !have_end) return PlyError("incomplete header (no format or no end_header)");
  header.body_offset = std::min(lines.position(), data.size());
  return header;
}

}  // namespace meshsmooth::io
