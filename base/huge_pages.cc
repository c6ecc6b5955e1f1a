#include "base/huge_pages.h"

#include <unistd.h>

#include <cstdlib>
#include <string>

#include "core/io/file_bytes.h"

namespace meshsmooth {

void UseHugePagesForLargeBuffers(char** argv) {
#if defined(__SANITIZE_ADDRESS__)
  return;  // ASan has its own allocator
#endif
  if (const char* opt = std::getenv("MESHSMOOTH_HUGE_PAGES"); opt != nullptr && std::string(opt) == "0") return;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  // Already set (by an earlier pass through here, or by the user): never exec twice.
  if (tunables != nullptr && std::string(tunables).find("glibc.malloc.hugetlb") != std::string::npos) return;
  // "always" needs no request and "never" grants none.
  absl::StatusOr<std::string> mode = ReadFileBytes("/sys/kernel/mm/transparent_hugepage/enabled");
  if (!mode.ok() || mode->find("[madvise]") == std::string::npos) return;
  std::string value = tunables != nullptr && *tunables != '\0' ? std::string(tunables) + ":" : std::string();
  // One arena: glibc gives each allocating thread an arena of its own, and a job runs on a
  // worker thread, where its decode, topology and encode ran slower than the same steps on the
  // main thread (docs/decisions.md, "Speed"; presumably the thread arenas' heaps get no
  // huge pages or are trimmed and faulted in again). Small allocations still avoid the arena's
  // lock through glibc's per-thread cache.
  value += "glibc.malloc.hugetlb=1:glibc.malloc.arena_max=1";
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // exec failed (no /proc, say): carry on with 4 KiB pages; the tunable stays set, so a child
  // process started later gets it without exec.
}

}  // namespace meshsmooth
