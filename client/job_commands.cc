#include "client/job_commands.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/commands.h"
#include "client/report.h"
#include "client/smooth_client.h"
#include "client/transfer.h"
#include "client/upload_quantization.h"
#include "server/job_store.h"
#include "server/options.h"

namespace meshsmooth::client {
namespace {

using Stub = v1::MeshSmoother::Stub;

using server::Sha256;

int Fail(const absl::Status& s) {
  std::cerr << "meshsmooth: " << s.message() << "\n";
  return s.code() == absl::StatusCode::kUnavailable ? kExitUnavailable : kExitFailure;
}

// A connection for the job commands: the channel, its stub, and (without --server) the
// in-process server, which has no job store.
struct Link {
  std::unique_ptr<server::Server> embedded;
  std::unique_ptr<Stub> stub;
};

absl::StatusOr<Link> Open(const ConnectionOptions& c) {
  Link link;
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = Connect(c, link.embedded);
  if (!channel.ok()) return channel.status();
  link.stub = v1::MeshSmoother::NewStub(*channel);
  return link;
}

// A context with the command's deadline and token, for one call.
using Contexts = std::function<absl::StatusOr<std::unique_ptr<grpc::ClientContext>>()>;

// Runs `call(contexts)` (`contexts` makes a context per call); when it fails with UNAVAILABLE
// (the connection broke, the server restarts) it runs again, up to --retries times, after
// 0.2 s, 0.4 s, ... 5 s: `call` must resume where the last attempt stopped.
template <typename Call>
absl::Status WithRetries(const ConnectionOptions& c, const std::string& what, Call&& call) {
  const auto deadline = CallDeadline(c);
  const Contexts contexts = [&]() -> absl::StatusOr<std::unique_ptr<grpc::ClientContext>> {
    auto context = std::make_unique<grpc::ClientContext>();
    if (absl::Status s = PrepareContext(c, *context, deadline); !s.ok()) return s;
    return context;
  };
  for (int attempt = 0;; ++attempt) {
    absl::Status s = call(contexts);
    if (s.ok() || s.code() != absl::StatusCode::kUnavailable || attempt >= c.retries) {
      return s.ok() ? s : WithConnectionHint(s, c);
    }
    const auto wait = std::chrono::milliseconds(std::min(5000, 200 << std::min(attempt, 5)));
    std::cerr << "meshsmooth: " << what << ": " << s.message() << "; resuming in " << wait.count() << " ms (retry "
              << attempt + 1 << " of " << c.retries << ")\n";
    std::this_thread::sleep_for(wait);
  }
}

std::string StateName(v1::JobState s) {
  std::string name = v1::JobState_Name(s);
  if (name.rfind("JOB_STATE_", 0) == 0) name = name.substr(10);
  return absl::AsciiStrToLower(name);
}

std::string Time(const google::protobuf::Timestamp& t) {
  if (t.seconds() == 0 && t.nanos() == 0) return "-";
  const std::time_t secs = static_cast<std::time_t>(t.seconds());
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// "running smoothing 120/400" and the like.
std::string Describe(const v1::Job& job) {
  std::string line = StateName(job.state());
  if (job.state() == v1::JOB_STATE_RUNNING && job.has_progress()) {
    std::string phase = v1::ProgressPhase_Name(job.progress().phase());
    if (phase.rfind("PROGRESS_PHASE_", 0) == 0) phase = absl::AsciiStrToLower(phase.substr(15));
    absl::StrAppend(&line, " ", phase);
    if (job.progress().total() > 0)
      absl::StrAppend(&line, " ", job.progress().iteration(), "/", job.progress().total());
  }
  if (job.state() == v1::JOB_STATE_FAILED) absl::StrAppend(&line, ": ", job.error().message());
  return line;
}

// Uploads `data` under `request_id` from the bytes the server holds, and commits it.
absl::Status Submit(Stub& stub, const ConnectionOptions& c, const std::string& request_id, const v1::JobSpec& spec,
                    const std::string& data, v1::Job* job) {
  const std::string sha = Sha256(data);
  return WithRetries(c, "upload", [&](const Contexts& contexts) -> absl::Status {
    absl::StatusOr<std::unique_ptr<grpc::ClientContext>> query = contexts();
    if (!query.ok()) return query.status();
    v1::QueryUploadRequest q;
    q.set_request_id(request_id);
    v1::SubmitResponse held;
    if (grpc::Status s = stub.QueryUpload(query->get(), q, &held); !s.ok()) return FromGrpc(s);
    if (held.committed()) {
      *job = held.job();
      return absl::OkStatus();
    }
    absl::StatusOr<std::unique_ptr<grpc::ClientContext>> context = contexts();
    if (!context.ok()) return context.status();
    v1::SubmitResponse response;
    std::unique_ptr<grpc::ClientWriter<v1::SubmitRequest>> writer = stub.Submit(context->get(), &response);
    v1::SubmitRequest request;
    v1::SubmitStart* start = request.mutable_start();
    start->set_request_id(request_id);
    *start->mutable_spec() = spec;
    start->set_total_bytes(data.size());
    start->set_sha256(sha);
    bool open = writer->Write(request);
    for (uint64_t offset = held.bytes_received(); open && offset < data.size(); offset += server::kMaxChunkBytes) {
      request.Clear();
      request.mutable_chunk()->set_offset(offset);
      request.mutable_chunk()->set_data(data.substr(offset, server::kMaxChunkBytes));
      open = writer->Write(request);
    }
    if (open) writer->WritesDone();
    if (grpc::Status s = writer->Finish(); !s.ok()) return FromGrpc(s);
    if (!response.committed()) {
      return absl::UnavailableError(
          absl::StrCat("the server holds ", response.bytes_received(), " of ", data.size(), " bytes"));
    }
    *job = response.job();
    return absl::OkStatus();
  });
}

absl::Status Get(Stub& stub, const ConnectionOptions& c, const std::string& job_id, v1::Job* job) {
  return WithRetries(c, "status", [&](const Contexts& contexts) -> absl::Status {
    absl::StatusOr<std::unique_ptr<grpc::ClientContext>> context = contexts();
    if (!context.ok()) return context.status();
    v1::GetJobRequest request;
    request.set_job_id(job_id);
    return FromGrpc(stub.GetJob(context->get(), request, job));
  });
}

// Follows the job from `after` to its end, printing a line per event when `print`; the job at
// its end.
absl::Status Watch(Stub& stub, const ConnectionOptions& c, const std::string& job_id, bool print, v1::Job* job) {
  uint64_t after = 0;
  return WithRetries(c, "watch", [&](const Contexts& contexts) -> absl::Status {
    absl::StatusOr<std::unique_ptr<grpc::ClientContext>> context = contexts();
    if (!context.ok()) return context.status();
    v1::WatchJobRequest request;
    request.set_job_id(job_id);
    request.set_after_sequence(after);
    std::unique_ptr<grpc::ClientReader<v1::JobEvent>> reader = stub.WatchJob(context->get(), request);
    v1::JobEvent event;
    while (reader->Read(&event)) {
      after = event.sequence();
      *job = event.job();
      if (print) std::cerr << job_id << " " << Describe(event.job()) << "\n";
    }
    if (grpc::Status s = reader->Finish(); !s.ok()) return FromGrpc(s);
    if (after == 0) return Get(stub, c, job_id, job);  // it had ended before the watch: the job as it is
    return absl::OkStatus();
  });
}

// The result into `output`: a partial file `output`.part grows across retries, checked against the
// result's SHA-256, then renamed.
absl::Status Fetch(Stub& stub, const ConnectionOptions& c, const std::string& job_id, const std::string& output) {
  const std::string part = output + ".part";
  std::ofstream out(part, std::ios::binary | std::ios::trunc);
  if (!out) return absl::InvalidArgumentError(absl::StrCat("cannot write ", part));
  std::string data;
  std::string sha;
  uint64_t total = 0;
  absl::Status s = WithRetries(c, "download", [&](const Contexts& contexts) -> absl::Status {
    absl::StatusOr<std::unique_ptr<grpc::ClientContext>> context = contexts();
    if (!context.ok()) return context.status();
    v1::FetchResultRequest request;
    request.set_job_id(job_id);
    request.set_offset(data.size());
    std::unique_ptr<grpc::ClientReader<v1::FetchResultResponse>> reader = stub.FetchResult(context->get(), request);
    v1::FetchResultResponse piece;
    while (reader->Read(&piece)) {
      data += piece.data();
      sha = piece.sha256();
      total = piece.total_bytes();
    }
    return FromGrpc(reader->Finish());
  });
  if (s.ok() && (data.size() != total || Sha256(data) != sha)) {
    s = absl::DataLossError(
        absl::StrCat("the result's ", data.size(), " bytes do not match its length ", total, " and SHA-256"));
  }
  if (s.ok()) {
    out.write(data.data(), static_cast<std::streamsize>(data.size()));
    out.close();
    if (!out) s = absl::InternalError(absl::StrCat("cannot write ", part));
  }
  std::error_code error;
  if (s.ok()) std::filesystem::rename(part, output, error);
  if (!s.ok() || error) std::filesystem::remove(part, error);
  return s;
}

}  // namespace

int RunSubmit(const JobCommand& command, const ConnectionOptions& c) {
  if (command.wait && !absl::EndsWithIgnoreCase(command.output, ".drc")) {
    std::cerr << "meshsmooth: submit --wait writes the result as Draco bytes: give -o FILE.drc\n";
    return kExitUsage;
  }
  absl::StatusOr<Upload> upload = PrepareUpload(command.input, /*with_attributes=*/true, /*gltf_draco=*/false,
                                                /*strength=*/{}, /*in_memory=*/false, command.quantize_upload);
  if (!upload.ok()) return Fail(upload.status());
  // On stderr: stdout is the job's id alone, for scripts.
  if (command.quantize_upload > 0.0)
    std::fprintf(stderr, "%s\n", DescribeUploadQuantization(upload->quantization).c_str());
  if (upload->origin.x != 0.0 || upload->origin.y != 0.0 || upload->origin.z != 0.0) {
    return Fail(absl::InvalidArgumentError(
        "the input lies far from the origin, and the job store keeps the positions relative to a local origin "
        "that a later fetch does not know: use meshsmooth smooth for it"));
  }
  v1::JobSpec spec;
  spec.set_flow(command.flow);
  spec.set_iterations(command.iterations);
  spec.set_callback_url(command.callback_url);
  const std::string request_id =
      !command.request_id.empty()
          ? command.request_id
          : absl::BytesToHexString(Sha256(absl::StrCat(spec.SerializeAsString(), Sha256(upload->draco))));
  absl::StatusOr<Link> link = Open(c);
  if (!link.ok()) return Fail(link.status());
  v1::Job job;
  if (absl::Status s = Submit(*link->stub, c, request_id, spec, upload->draco, &job); !s.ok()) return Fail(s);
  std::printf("%s\n", job.job_id().c_str());
  std::fflush(stdout);
  if (!command.wait) return 0;
  if (absl::Status s = Watch(*link->stub, c, job.job_id(), /*print=*/true, &job); !s.ok()) return Fail(s);
  if (job.state() != v1::JOB_STATE_SUCCEEDED) return Fail(absl::AbortedError(Describe(job)));
  if (absl::Status s = Fetch(*link->stub, c, job.job_id(), command.output); !s.ok()) return Fail(s);
  return 0;
}

int RunStatus(const JobCommand& command, const ConnectionOptions& c) {
  absl::StatusOr<Link> link = Open(c);
  if (!link.ok()) return Fail(link.status());
  v1::Job job;
  if (absl::Status s = Get(*link->stub, c, command.job_id, &job); !s.ok()) return Fail(s);
  std::printf("job %s (request %s): %s\n", job.job_id().c_str(), job.request_id().c_str(), Describe(job).c_str());
  std::printf("created %s  started %s  ended %s  attempts %u  upload %llu bytes\n", Time(job.create_time()).c_str(),
              Time(job.start_time()).c_str(), Time(job.end_time()).c_str(), job.attempts(),
              static_cast<unsigned long long>(job.upload_bytes()));
  if (job.state() == v1::JOB_STATE_SUCCEEDED) {
    std::printf("result %llu bytes, sha256 %s\n", static_cast<unsigned long long>(job.result_bytes()),
                absl::BytesToHexString(job.result_sha256()).c_str());
    PrintSummary(job.summary());
  }
  return 0;
}

int RunWatch(const JobCommand& command, const ConnectionOptions& c) {
  absl::StatusOr<Link> link = Open(c);
  if (!link.ok()) return Fail(link.status());
  v1::Job job;
  if (absl::Status s = Watch(*link->stub, c, command.job_id, /*print=*/true, &job); !s.ok()) return Fail(s);
  std::printf("%s\n", StateName(job.state()).c_str());
  return job.state() == v1::JOB_STATE_SUCCEEDED ? 0 : kExitFailure;
}

int RunFetch(const JobCommand& command, const ConnectionOptions& c) {
  if (!absl::EndsWithIgnoreCase(command.output, ".drc")) {
    std::cerr << "meshsmooth: fetch writes the result as the service sends it, Draco bytes: give -o FILE.drc\n";
    return kExitUsage;
  }
  absl::StatusOr<Link> link = Open(c);
  if (!link.ok()) return Fail(link.status());
  if (absl::Status s = Fetch(*link->stub, c, command.job_id, command.output); !s.ok()) return Fail(s);
  return 0;
}

int RunCancel(const JobCommand& command, const ConnectionOptions& c) {
  absl::StatusOr<Link> link = Open(c);
  if (!link.ok()) return Fail(link.status());
  v1::Job job;
  absl::Status s = WithRetries(c, "cancel", [&](const Contexts& contexts) -> absl::Status {
    absl::StatusOr<std::unique_ptr<grpc::ClientContext>> context = contexts();
    if (!context.ok()) return context.status();
    v1::CancelJobRequest request;
    request.set_job_id(command.job_id);
    return FromGrpc(link->stub->CancelJob(context->get(), request, &job));
  });
  if (!s.ok()) return Fail(s);
  std::printf("%s\n", StateName(job.state()).c_str());
  return 0;
}

int RunJobs(const JobCommand& command, const ConnectionOptions& c) {
  absl::StatusOr<Link> link = Open(c);
  if (!link.ok()) return Fail(link.status());
  v1::ListJobsRequest request;
  if (!command.state.empty()) {
    v1::JobState state;
    if (!v1::JobState_Parse("JOB_STATE_" + absl::AsciiStrToUpper(command.state), &state)) {
      std::cerr << "meshsmooth: --state must be queued, running, succeeded, failed or cancelled\n";
      return kExitUsage;
    }
    request.add_states(state);
  }
  do {
    v1::ListJobsResponse page;
    absl::Status s = WithRetries(c, "jobs", [&](const Contexts& contexts) -> absl::Status {
      absl::StatusOr<std::unique_ptr<grpc::ClientContext>> context = contexts();
      if (!context.ok()) return context.status();
      return FromGrpc(link->stub->ListJobs(context->get(), request, &page));
    });
    if (!s.ok()) return Fail(s);
    for (const v1::Job& job : page.jobs()) {
      std::printf("%s  %-9s  %s  %s\n", job.job_id().c_str(), StateName(job.state()).c_str(),
                  Time(job.create_time()).c_str(), job.request_id().c_str());
    }
    request.set_page_token(page.next_page_token());
  } while (!request.page_token().empty());
  return 0;
}

}  // namespace meshsmooth::client
