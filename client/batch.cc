#include "client/batch.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/batch_plan.h"
#include "client/json.h"
#include "client/report.h"
#include "client/smooth_file.h"
#include "client/transfer.h"
#include "server/log.h"

namespace meshsmooth::client {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// "INPUT: ERROR", or the error alone when it names the input first (as the readers' errors do).
std::string NamedError(const std::string& input, const std::string& error) {
  return absl::StartsWith(error, input + ":") ? error : absl::StrCat(input, ": ", error);
}

int Usage(const absl::Status& s) {
  std::fprintf(stderr, "meshsmooth: %s\n", std::string(s.message()).c_str());
  return kExitUsage;
}

// The files of the batch, or its refusal (exit 2): what PlanBatch refuses, glTF inputs and
// --edgebreaker for a file written over its input's faces.
absl::StatusOr<std::vector<BatchFile>> Plan(const SmoothOptions& o, const BatchOptions& b) {
  absl::StatusOr<std::vector<std::string>> inputs = ExpandInputs(b.inputs, b.list_file);
  if (!inputs.ok()) return inputs.status();
  for (const std::string& input : *inputs) {
    // Reading a scene forks a child first (GltfScene::ReadInChildFirst), which the batch's threads forbid.
    if (IsGltfPath(input)) {
      return absl::InvalidArgumentError(absl::StrCat(input, ": a glTF scene is smoothed on its own (meshsmooth smooth ",
                                                     input, " -o OUT.glb), not in a batch"));
    }
  }
  absl::StatusOr<std::vector<BatchFile>> files = PlanBatch(*inputs, o.output, b.format);
  if (!files.ok()) return files.status();
  for (const BatchFile& f : *files) {
    if (o.edgebreaker && !EdgebreakerFits(f.input, f.output)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--edgebreaker reorders the result's vertices; it applies to .drc or glTF outputs (or .drc inputs), and ",
          f.input, " would be written to ", f.output, ": give --format drc, or leave --edgebreaker out"));
    }
  }
  return files;
}

// One batch under way: the workers take the files in order, each reports when it is done.
class BatchRun {
 public:
  BatchRun(const SmoothOptions& o, const ConnectionOptions& c, std::vector<BatchFile> files)
      : options_(o), files_(std::move(files)), service_(c), outcomes_(files_.size()) {}

  int Run(int jobs);

 private:
  void Work();
  FileOutcome SmoothOne(size_t i, std::vector<std::string>& warnings);
  void Report(size_t i, const FileOutcome& f, const std::vector<std::string>& warnings, double seconds);
  int Finish(double seconds);

  bool chatty() const { return !options_.quiet && !options_.json; }

  const SmoothOptions& options_;
  const std::vector<BatchFile> files_;
  ServiceLink service_;
  JobCancels cancels_;
  std::atomic<size_t> next_{0};
  std::mutex mu_;  // guards the members below and the lines printed
  size_t finished_ = 0;
  std::vector<std::optional<FileOutcome>> outcomes_;  // per file, once it ended
  std::set<std::string> warned_;                      // warnings about the options, printed once for the batch
};

int BatchRun::Run(int jobs) {
  const Clock::time_point start = Clock::now();
  {
    InterruptWatcher watcher([this] { cancels_.Cancel(); });
    std::vector<std::thread> workers;
    const size_t count = std::min<size_t>(std::max(jobs, 1), files_.size());
    for (size_t w = 0; w < count; ++w) workers.emplace_back([this] { Work(); });
    for (std::thread& t : workers) t.join();
  }
  return Finish(SecondsSince(start));
}

void BatchRun::Work() {
  for (;;) {
    const size_t i = next_.fetch_add(1);
    if (i >= files_.size() || cancels_.cancelled()) return;
    const Clock::time_point start = Clock::now();
    std::vector<std::string> warnings;
    FileOutcome f = SmoothOne(i, warnings);
    Report(i, f, warnings, SecondsSince(start));
    std::lock_guard<std::mutex> lock(mu_);
    outcomes_[i] = std::move(f);
  }
}

FileOutcome BatchRun::SmoothOne(size_t i, std::vector<std::string>& warnings) {
  SmoothOptions o = options_;
  o.input = files_[i].input;
  o.output = files_[i].output;
  // One id per job: --job-id ID names the batch's jobs ID-1, ID-2, ... in input order.
  if (!o.job_id.empty()) o.job_id = absl::StrCat(options_.job_id, "-", i + 1);
  if (absl::Status s = CheckInputOutput(o, warnings); !s.ok()) {
    FileOutcome f;
    f.exit_code = kExitFailure;
    f.error = std::string(s.message());
    return f;
  }
  FileHooks hooks;
  if (!options_.quiet && !options_.json) {
    hooks.retry = [this, &o](int retry, const absl::Status& s, std::chrono::milliseconds wait) {
      std::lock_guard<std::mutex> lock(mu_);
      PrintRetry(o.input + ": ", retry, s, wait);
    };
  }
  return SmoothFile(o, service_, cancels_, hooks);
}

void BatchRun::Report(size_t i, const FileOutcome& f, const std::vector<std::string>& warnings, double seconds) {
  const BatchFile& file = files_[i];
  std::lock_guard<std::mutex> lock(mu_);
  const size_t k = ++finished_;
  for (const std::string& w : warnings) {
    if (warned_.insert(w).second) std::fprintf(stderr, "meshsmooth: warning: %s\n", w.c_str());
  }
  std::vector<std::string> own = f.upload_warnings;
  own.insert(own.end(), f.summary.warnings().begin(), f.summary.warnings().end());
  if (!f.dropped.empty()) own.push_back(absl::StrCat("not kept: ", absl::StrJoin(f.dropped, "; ")));
  for (const std::string& w : own) std::fprintf(stderr, "meshsmooth: warning: %s: %s\n", file.input.c_str(), w.c_str());
  const bool ok = f.exit_code == 0;
  if (options_.json) {
    std::string record =
        absl::StrCat("{\"input\":", server::JsonQuote(file.input), ",\"output\":", server::JsonQuote(file.output),
                     ",\"ok\":", ok ? "true" : "false");
    if (!ok) absl::StrAppend(&record, ",\"exit_code\":", f.exit_code, ",\"error\":", server::JsonQuote(f.error));
    absl::StrAppend(&record, ",\"seconds\":", seconds);
    if (ok) absl::StrAppend(&record, ",\"summary\":", ToJsonLine(SummaryWithWarnings(f)));
    std::printf("%s}\n", record.c_str());
  } else if (!options_.quiet) {
    std::fprintf(stderr, "[%zu/%zu] %s %s (%.2f s)\n", k, files_.size(), file.input.c_str(),
                 ok                                ? "done"
                 : f.exit_code == kExitInterrupted ? "cancelled"
                                                   : "FAILED",
                 seconds);
    if (ok) {
      const std::string note = f.upload_note.empty() ? "" : absl::StrCat("; ", f.upload_note);
      std::printf("%s -> %s: %s%s; %.2f s\n", file.input.c_str(), file.output.c_str(),
                  OneLineSummary(f.summary).c_str(), note.c_str(), seconds);
    } else {
      std::printf("failed: %s\n", NamedError(file.input, f.error).c_str());
    }
  }
  std::fflush(stdout);
}

int BatchRun::Finish(double seconds) {
  const bool interrupted = cancels_.cancelled();
  std::vector<size_t> failed;
  size_t succeeded = 0, unreachable = 0;
  for (size_t i = 0; i < files_.size(); ++i) {
    const std::optional<FileOutcome>& f = outcomes_[i];
    if (!f.has_value() || f->exit_code == kExitInterrupted) continue;  // not started, or cancelled
    if (f->exit_code == 0) {
      ++succeeded;
    } else {
      failed.push_back(i);
      if (f->exit_code == kExitUnavailable) ++unreachable;
    }
  }
  if (options_.json) {
    std::vector<std::string> names;
    for (size_t i : failed) names.push_back(server::JsonQuote(files_[i].input));
    std::printf(
        "{\"files\":%zu,\"succeeded\":%zu,\"failed\":%zu,\"failed_inputs\":[%s],\"interrupted\":%s,"
        "\"seconds\":%g}\n",
        files_.size(), succeeded, failed.size(), absl::StrJoin(names, ",").c_str(), interrupted ? "true" : "false",
        seconds);
  } else if (!options_.quiet) {
    std::printf("%zu %s: %zu smoothed, %zu failed%s (%.2f s)\n", files_.size(), files_.size() == 1 ? "file" : "files",
                succeeded, failed.size(), interrupted ? ", the rest cancelled" : "", seconds);
  }
  std::fflush(stdout);
  if (!failed.empty()) {
    std::fprintf(stderr, "meshsmooth: %zu of %zu files failed:\n", failed.size(), files_.size());
    for (size_t i : failed) std::fprintf(stderr, "  %s\n", NamedError(files_[i].input, outcomes_[i]->error).c_str());
  }
  if (interrupted) {
    std::fprintf(stderr, "meshsmooth: interrupted; the jobs in flight were cancelled (%zu of %zu files written)\n",
                 succeeded, files_.size());
    return kExitInterrupted;
  }
  if (failed.empty()) return 0;
  return succeeded == 0 && unreachable == failed.size() ? kExitUnavailable : kExitFailure;
}

}  // namespace

int RunBatch(const SmoothOptions& o, const ConnectionOptions& c, const BatchOptions& b) {
  absl::StatusOr<std::vector<BatchFile>> files = Plan(o, b);
  if (!files.ok()) return Usage(files.status());
  if (absl::Status s = PrepareOutputFolder(o.output); !s.ok()) return Usage(s);
  BatchRun run(o, c, *std::move(files));
  return run.Run(b.jobs);
}

}  // namespace meshsmooth::client
