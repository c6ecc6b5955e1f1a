#include "core/io/crash_report.h"

#include <execinfo.h>
#include <signal.h>
#include <string.h>
#include <ucontext.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <optional>

#include "absl/debugging/symbolize.h"

// Sanitizers' hooks (present in sanitized builds only).
extern "C" void __sanitizer_set_report_fd(void* fd) __attribute__((weak));
extern "C" void __sanitizer_set_death_callback(void (*callback)()) __attribute__((weak));

namespace meshsmooth {
namespace {

int report_fd = -1;

// One line of a report, built without allocating (the signal handler's).
class Line {
 public:
  void Add(const char* s) {
    while (*s != '\0' && size_ < sizeof text_ - 1) text_[size_++] = *s++;
  }
  void AddNumber(uintptr_t value, unsigned base) {
    char digits[24];
    int n = 0;
    do {
      digits[n++] = "0123456789abcdef"[value % base];
      value /= base;
    } while (value != 0);
    while (n > 0 && size_ < sizeof text_ - 1) text_[size_++] = digits[--n];
  }
  void WriteTo(int fd) {
    text_[size_++] = '\n';
    for (size_t done = 0; done < size_;) {
      const ssize_t n = write(fd, text_ + done, size_ - done);
      if (n <= 0) return;
      done += static_cast<size_t>(n);
    }
  }

 private:
  char text_[1280];
  size_t size_ = 0;
};

// The address of the instruction a signal interrupted, from the handler's context.
const void* InterruptedPc(void* context) {
  const mcontext_t& m = static_cast<ucontext_t*>(context)->uc_mcontext;
#if defined(__x86_64__)
  return reinterpret_cast<const void*>(m.gregs[REG_RIP]);
#elif defined(__aarch64__)
  return reinterpret_cast<const void*>(m.pc);
#else
  return nullptr;
#endif
}

// Writes the signal's name and the stack from the interrupted instruction on to report_fd; the
// signal then kills the process (SA_RESETHAND put back its default action).
void OnDeadlySignal(int sig, siginfo_t*, void* context) {
  Line summary;
  summary.Add("SUMMARY: deadly signal: ");
  const char* name = sigabbrev_np(sig);
  summary.Add(name != nullptr ? name : "?");
  summary.WriteTo(report_fd);
  void* pcs[64];
  const int n = backtrace(pcs, 64);
  // Above the interrupted frame: this handler, the signal's return path and, in a sanitized
  // build, the sanitizer's interceptor of backtrace. All frames when it is not found.
  int first = 0;
  while (first < n && pcs[first] != InterruptedPc(context)) ++first;
  if (first == n) first = 0;
  for (int i = first; i < n; ++i) {
    Line frame;
    frame.Add("    #");
    frame.AddNumber(static_cast<uintptr_t>(i - first), 10);
    frame.Add(" 0x");
    frame.AddNumber(reinterpret_cast<uintptr_t>(pcs[i]), 16);
    char function[1024];
    // A return address less one lies in the call, so in the caller.
    if (absl::Symbolize(static_cast<char*>(pcs[i]) - (i > first ? 1 : 0), function, sizeof function)) {
      frame.Add(" in ");
      frame.Add(function);
    }
    frame.WriteTo(report_fd);
  }
  raise(sig);
}

// The function of a frame line, a sanitizer's ("    #3 0x4a3b2c in draco::Foo(int) /a/foo.cc:12:3")
// or OnDeadlySignal's: nullopt for a line that is not a frame, "" for a frame without a name.
std::optional<std::string_view> FrameFunction(std::string_view line) {
  line.remove_prefix(std::min(line.size(), line.find_first_not_of(' ')));
  if (line.size() < 2 || line[0] != '#' || !std::isdigit(static_cast<unsigned char>(line[1]))) return std::nullopt;
  const size_t in = line.find(" in ");
  return in == std::string_view::npos ? std::string_view() : line.substr(in + 4);
}

// The qualified name at the start of `function`, a demangled name with its parameters and maybe
// a location after them: "void draco::Foo<int>(int) const /a.h:3" -> "draco::Foo<int>". It ends
// at the parameters' parenthesis or before a location; "(anonymous namespace)" and operators'
// names belong to it, and a word before it (a return type) does not.
std::string_view QualifiedName(std::string_view function) {
  constexpr std::string_view kAnonymous = "(anonymous namespace)", kOperatorSymbols = "<>=!+-*/%&|^~[],";
  size_t start = 0, i = 0;
  for (int depth = 0; i < function.size(); ++i) {
    const std::string_view rest = function.substr(i);
    if (depth == 0 && rest.starts_with("operator")) {
      i += 8;
      if (function.substr(i).starts_with("()")) i += 2;
      while (i < function.size() && kOperatorSymbols.find(function[i]) != std::string_view::npos) ++i;
      --i;
    } else if (rest.starts_with(kAnonymous)) {
      i += kAnonymous.size() - 1;
    } else if (rest[0] == '<') {
      ++depth;
    } else if (rest[0] == '>' && depth > 0) {
      --depth;
    } else if (depth == 0 && rest[0] == '(') {
      break;
    } else if (depth == 0 && rest[0] == ' ') {
      if (rest.size() > 1 && (rest[1] == '(' || rest[1] == '/' || rest[1] == '.')) break;  // a location follows
      start = i + 1;
    }
  }
  return function.substr(start, i - start);
}

// Whose code a function is, by its outermost namespace.
CrashOwner OwnerOf(std::string_view name) {
  // Mangled, as Symbolize leaves a name it cannot demangle: "_ZN5draco3FooEv", "_ZNK10meshsmooth...".
  if (name.starts_with("_ZN")) {
    name.remove_prefix(name.starts_with("_ZNK") ? 4 : 3);
    if (name.starts_with("5draco") || name.starts_with("8tinygltf")) return CrashOwner::kDraco;
    return name.starts_with("10meshsmooth") ? CrashOwner::kMeshsmooth : CrashOwner::kUnknown;
  }
  const std::string_view top = name.substr(0, name.find("::"));
  if (top == "draco" || top == "tinygltf") return CrashOwner::kDraco;
  return top == "meshsmooth" ? CrashOwner::kMeshsmooth : CrashOwner::kUnknown;
}

}  // namespace

void SendCrashReportsTo(int fd) {
  report_fd = fd;
  if (__sanitizer_set_report_fd != nullptr) {
    __sanitizer_set_report_fd(reinterpret_cast<void*>(static_cast<intptr_t>(fd)));
  }
  if (__sanitizer_set_death_callback != nullptr) __sanitizer_set_death_callback(nullptr);
  void* first;
  backtrace(&first, 1);  // loads the unwinder (libgcc_s) now rather than in the handler
  constexpr size_t kHandlerStack = 1 << 18;
  stack_t handler_stack{};
  handler_stack.ss_sp = new char[kHandlerStack];  // the process's own until it ends
  handler_stack.ss_size = kHandlerStack;
  sigaltstack(&handler_stack, nullptr);
  struct sigaction action {};
  action.sa_sigaction = OnDeadlySignal;
  action.sa_flags = SA_SIGINFO | SA_ONSTACK | SA_RESETHAND;
  sigemptyset(&action.sa_mask);
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGTRAP}) sigaction(sig, &action, nullptr);
}

CrashReport ReadCrashReport(std::string_view report) {
  std::vector<std::string_view> lines;
  while (!report.empty()) {
    const size_t end = std::min(report.find('\n'), report.size());
    lines.push_back(report.substr(0, end));
    report.remove_prefix(std::min(report.size(), end + 1));
  }
  CrashReport out;
  for (std::string_view line : lines) {
    const size_t at = line.find("SUMMARY: ");
    if (at == std::string_view::npos) continue;
    std::string_view kind = line.substr(at + 9);
    if (const size_t colon = kind.find(": "); colon != std::string_view::npos) kind.remove_prefix(colon + 2);
    out.kind = std::string(kind.substr(0, kind.find(' ')));
    break;
  }
  bool in_stack = false;
  for (std::string_view line : lines) {
    const std::optional<std::string_view> function = FrameFunction(line);
    if (!function.has_value()) {
      if (in_stack) break;  // the first stack ended
      continue;
    }
    in_stack = true;
    const std::string_view name = QualifiedName(*function);
    const CrashOwner owner = OwnerOf(name);
    if (owner == CrashOwner::kUnknown) continue;
    if (out.frames.empty()) out.owner = owner;
    out.frames.emplace_back(name);
  }
  return out;
}

}  // namespace meshsmooth
