// Internal to core/io: one parser and one writer per format, and the text helpers they share.
#pragma once

#include <charconv>
#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/io/mesh_io.h"

namespace meshsmooth::io {

absl::StatusOr<Mesh> ParseObj(std::string_view data, ReadInfo& info);
absl::StatusOr<Mesh> ParsePly(std::string_view data, ReadInfo& info);
absl::StatusOr<Mesh> ParseOff(std::string_view data, ReadInfo& info);
absl::StatusOr<Mesh> ParseStl(std::string_view data, ReadInfo& info);

std::string WriteObj(const Mesh& mesh);
// InvalidArgument when the mesh has colours but not one per vertex.
absl::StatusOr<std::string> WritePly(const Mesh& mesh, bool binary, bool double_positions = false);
std::string WriteOff(const Mesh& mesh);
std::string WriteStl(const Mesh& mesh);

// Debian's Abseil is built with its own string_view, not std::string_view: StrCat needs this bridge.
inline absl::string_view Sv(std::string_view s) { return {s.data(), s.size()}; }

// Splits text into lines (LF or CRLF) and whitespace-separated tokens.
class LineReader {
 public:
  explicit LineReader(std::string_view data) : data_(data) {}
  // Next line without its terminator; false at the end.
  bool Next(std::string_view& line) {
    if (pos_ >= data_.size()) return false;
    size_t end = data_.find('\n', pos_);
    if (end == std::string_view::npos) end = data_.size();
    line = data_.substr(pos_, end - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = end + 1;
    ++line_number_;
    return true;
  }
  int64_t line_number() const { return line_number_; }
  size_t position() const { return pos_; }

 private:
  std::string_view data_;
  size_t pos_ = 0;
  int64_t line_number_ = 0;
};

inline bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

// Pops the next whitespace-separated token from `s`; empty when none is left.
inline std::string_view NextToken(std::string_view& s) {
  size_t i = 0;
  while (i < s.size() && IsSpace(s[i])) ++i;
  size_t j = i;
  while (j < s.size() && !IsSpace(s[j])) ++j;
  std::string_view tok = s.substr(i, j - i);
  s.remove_prefix(j);
  return tok;
}

inline bool ParseDouble(std::string_view tok, double& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return ec == std::errc() && ptr == tok.data() + tok.size();
}

inline bool ParseInt(std::string_view tok, int64_t& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return ec == std::errc() && ptr == tok.data() + tok.size();
}

// Maps a parsed index to int32, sending anything unrepresentable to -1 (out of range: the
// validation report counts the face and the topology leaves it out).
inline int32_t ClampIndex(int64_t i) { return (i < 0 || i > INT32_MAX) ? -1 : static_cast<int32_t>(i); }

// Shortest decimal text that reads back to the same double.
inline void AppendDouble(std::string& out, double v) {
  char buf[32];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, ec == std::errc() ? ptr : buf);
}

// "x y z" of a point, each coordinate as AppendDouble writes it (OBJ and OFF vertices).
inline void AppendPoint(std::string& out, const Vec3& p) {
  AppendDouble(out, p.x);
  out += ' ';
  AppendDouble(out, p.y);
  out += ' ';
  AppendDouble(out, p.z);
}

}  // namespace meshsmooth::io
