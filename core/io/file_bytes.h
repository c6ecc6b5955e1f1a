// Whole files in one go: the one place the project reads or writes a file as a string of bytes
// (meshes, Draco bitstreams, certificates, token files).
#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace meshsmooth {

// The whole content of the file at `path`. Errors name the path and the system's reason, with
// the code errno maps to: "cannot open 'x.obj': No such file or directory" is NotFound,
// an unreadable file PermissionDenied, a directory FailedPrecondition ("cannot read ...").
absl::StatusOr<std::string> ReadFileBytes(const std::string& path);

// Appends to `bytes` everything left to read from the open descriptor `fd` (a pipe: until every
// writer has closed it): 0, or the errno of the read that failed.
int ReadToEnd(int fd, std::string* bytes);

// Writes `bytes` to `path` (created or truncated): PermissionDenied when it cannot be opened,
// DataLoss when writing fails.
absl::Status WriteFileBytes(const std::string& path, std::string_view bytes);

// A secret kept in a text file, such as a bearer token: the file's content without the
// whitespace at either end (editors add a final newline; the rule is the same for the server
// and the client). InvalidArgument naming the path when the file cannot be read or holds
// nothing but whitespace.
absl::StatusOr<std::string> ReadTokenFile(const std::string& path);

}  // namespace meshsmooth
