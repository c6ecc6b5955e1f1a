// A crash in a child process, told apart by whose code crashed: Draco's (libdraco, with the copy
// of tinygltf inside it) or meshsmooth's. GltfScene::ReadInChildFirst runs Draco's glTF reader
// and writer, and meshsmooth's code around them, in a child: a crash in Draco's frames refuses a
// malformed file, a crash in ours is a bug of ours.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace meshsmooth {

// The payload (absl::Status::SetPayload) of a status made from a child's crash: the child's
// crash report, as ReadCrashReport reads it.
inline constexpr char kCrashReportPayload[] = "meshsmooth/crash-report";

// Sends this process's crash reports to `fd`, for a child forked to run code that may crash:
//   - a sanitizer's report (sanitized builds), and nothing that another part of the program set
//     to run on a sanitizer's death (libFuzzer's saving of the input as its own finding);
//   - on SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT or SIGTRAP (in place of any other handler, a
//     sanitizer's or libFuzzer's), the line "SUMMARY: deadly signal: SEGV" and the stack in the
//     sanitizers' format ("    #0 0x4a3b2c in draco::Foo()", names from the executable's symbol
//     table), on a stack of its own (a stack overflow is reported too); then the signal kills
//     the process.
void SendCrashReportsTo(int fd);

enum class CrashOwner {
  kUnknown,     // no frame names either
  kDraco,       // namespace draco or tinygltf
  kMeshsmooth,  // namespace meshsmooth
};

struct CrashReport {
  CrashOwner owner = CrashOwner::kUnknown;
  // What the report's SUMMARY line calls the crash ("heap-buffer-overflow", "SEGV"), or "".
  std::string kind;
  // The crashing stack's frames in Draco's code or ours, top first, each a function's qualified
  // name without its return type and parameters ("draco::GltfDecoder::SetValuesPerFace").
  std::vector<std::string> frames;
};

// Reads a crash report, a sanitizer's or SendCrashReportsTo's: its first stack (a heap
// overflow's report goes on with the allocation's) decides. The owner is that of the topmost
// frame in Draco's code or ours; the frames above it (a sanitizer's interceptors, libc, the
// standard library, Abseil, Eigen, nlohmann::json) are passed over, since they run for their
// caller.
CrashReport ReadCrashReport(std::string_view report);

}  // namespace meshsmooth
