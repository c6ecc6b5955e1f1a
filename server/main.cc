// meshsmoothd: the meshsmooth gRPC server.
//
// Prints "meshsmoothd listening on HOST:PORT" on stdout once it serves (with --listen
// HOST:0 the port is the one the system picked), preceded with --metrics-listen by
// "meshsmoothd metrics on HOST:PORT". SIGINT/SIGTERM shut it down gracefully: it exits as soon
// as the last running job has sent its result. Exit codes: 0 after a clean shutdown; 1 when it
// cannot start, when the grace cut a running job, or when a shutdown had to be cut short at
// grace + 1 s; 2 for a bad command line.
#include <signal.h>

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#endif

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <utility>

#include "CLI/CLI.hpp"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/time.h"
#include "base/huge_pages.h"
#include "base/kernel_environment.h"
#include "base/shutdown_signals.h"
#include "core/io/file_bytes.h"
#include "server/admission.h"
#include "server/log.h"
#include "server/server.h"

namespace {

// Exits with `code` at once, skipping static destructors and gRPC's library teardown; under
// AddressSanitizer the leak check runs first, as it would at a normal exit.
[[noreturn]] void ExitWithoutTeardown(int code) {
#if defined(__SANITIZE_ADDRESS__)
  __lsan_do_leak_check();
#endif
  std::fflush(stdout);
  std::fflush(stderr);
  std::_Exit(code);
}

}  // namespace

int main(int argc, char** argv) {
  meshsmooth::UseHugePagesForLargeBuffers(argv);  // first: may re-execute the program
  meshsmooth::ApplyKernelEnvironment();
  using meshsmooth::server::ServerOptions;
  ServerOptions o;
  std::string token_file;
  CLI::App app{"meshsmoothd: the meshsmooth smoothing server (gRPC, meshsmooth.v1.MeshSmoother)"};
  app.add_option("--listen", o.listen, "host:port to listen on; port 0 picks a free one")->capture_default_str();
  app.add_option("--workers", o.workers, "jobs smoothed at once; 0 = hardware threads")->capture_default_str();
  app.add_option("--queue-depth", o.queue_depth, "jobs that may wait for a worker; more get RESOURCE_EXHAUSTED")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--threads-per-job", o.threads_per_job, "threads of one job's vertex loops; 0 = hardware threads")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-upload-bytes", o.max_upload_bytes, "largest Draco upload of one job")->capture_default_str();
  app.add_option("--max-vertices", o.max_vertices, "largest mesh, in vertices")->capture_default_str();
  app.add_option("--max-iterations", o.max_iterations, "most iterations one job may ask for")->capture_default_str();
  app.add_option("--max-job-bytes", o.max_job_bytes,
                 "largest memory one job may need, by its estimate from the counts at the head of its upload "
                 "(about 270 bytes a vertex for the default job; docs/deployment.md): beyond, RESOURCE_EXHAUSTED "
                 "naming both figures before the rest of the upload is kept; 0 = no bound")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-job-seconds", o.max_job_seconds,
                 "time limit of one job on its worker, decode to encode (DEADLINE_EXCEEDED)")
      ->capture_default_str();
  app.add_option("--max-concurrent-streams", o.max_concurrent_streams, "Smooth calls open at once")
      ->capture_default_str();
  app.add_option("--upload-idle-seconds", o.upload_idle_seconds,
                 "an upload that sends no message for this long ends with DEADLINE_EXCEEDED; 0 = never")
      ->capture_default_str();
  app.add_option("--max-queue-wait", o.max_queue_wait_seconds,
                 "seconds a job may wait for a worker; then RESOURCE_EXHAUSTED, so the client retries elsewhere; "
                 "0 = it waits its turn")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-buffered-bytes", o.max_buffered_bytes,
                 absl::StrCat("bytes held by uploads in flight and queued jobs; beyond, uploads get "
                              "RESOURCE_EXHAUSTED; 0 = a quarter of this machine's memory (",
                              meshsmooth::server::DefaultBufferedBytes(), " here)"))
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--grace-seconds", o.grace_seconds,
                 "on SIGINT/SIGTERM, time running jobs get to finish; the process exits within this + 1 s")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--tls-cert", o.tls_cert_file, "PEM certificate chain; with --tls-key enables TLS");
  app.add_option("--tls-key", o.tls_key_file, "PEM private key");
  app.add_option("--auth-token-file", token_file,
                 "file holding a bearer token; calls must then send 'authorization: Bearer <token>'");
  app.add_flag(
      "--quiet", [&o](int64_t) { o.log_jobs = false; }, "no per-job log lines (refused calls are still logged)");
  std::string log_format = "text";
  app.add_option("--log-format", log_format,
                 "text: lines for a terminal; json: one JSON object a line on stderr (time, level, event; a job's "
                 "id, flow, vertices, iterations, stop reason, status, error, peer and each step's seconds; a "
                 "refused call's method, reason, status, error, peer and job id) for a log pipeline")
      ->capture_default_str()
      ->check(CLI::IsMember({"text", "json"}));
  app.add_option("--job-store", o.job_store,
                 "the job store for jobs that outlive a connection (Submit, GetJob, WatchJob, FetchResult, ...): a "
                 "directory (a SQLite database, made when missing, one meshsmoothd per directory; the container image "
                 "has /var/lib/meshsmooth/jobs for a volume), or postgresql://USER@HOST:PORT/DB for a PostgreSQL "
                 "database that any number of replicas share (the password from PGPASSWORD or ~/.pgpass rather "
                 "than in the URI); default: none, and those methods answer UNIMPLEMENTED");
  std::string retention = "24h";
  app.add_option("--job-retention", retention,
                 "how long the job store keeps an ended job and its result after its end (e.g. 24h, 30m, 90s)")
      ->capture_default_str();
  std::string lease = "30s";
  app.add_option("--job-lease", lease,
                 "how long a running job stays this replica's without a renewal (renewed twice a second while it "
                 "runs); a job whose replica died is run again by another one this long after its last renewal")
      ->capture_default_str();
  app.add_option("--job-store-max-bytes", o.job_store_max_bytes,
                 "bytes of uploads and results the job store may hold; an upload beyond gets RESOURCE_EXHAUSTED "
                 "after ended jobs are forgotten, oldest first, to make room")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  std::string callback_secret_file;
  app.add_option("--callback-secret-file", callback_secret_file,
                 "file holding the key of the completion callbacks' HMAC-SHA256 (JobSpec.callback_url: a POST of the "
                 "ended job, header X-Meshsmooth-Signature: sha256=HEX); default: none, and a submit naming a "
                 "callback is INVALID_ARGUMENT");
  app.add_option("--metrics-listen", o.metrics_listen,
                 "host:port of a Prometheus endpoint (GET /metrics; port 0 picks a free one); default: none");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (absl::Duration d; absl::ParseDuration(retention, &d) && d > absl::ZeroDuration()) {
    o.job_retention_seconds = absl::ToDoubleSeconds(d);
  } else {
    std::fprintf(stderr, "--job-retention: '%s' is not a positive duration (e.g. 24h, 30m, 90s)\n", retention.c_str());
    return 2;
  }
  if (absl::Duration d; absl::ParseDuration(lease, &d) && d >= absl::Seconds(1)) {
    o.job_lease_seconds = absl::ToDoubleSeconds(d);
  } else {
    std::fprintf(stderr, "--job-lease: '%s' is not a duration of 1 s or more (e.g. 30s, 2m)\n", lease.c_str());
    return 2;
  }
  o.log_format = log_format == "json" ? meshsmooth::server::LogFormat::kJson : meshsmooth::server::LogFormat::kText;
  // The bearer token and the callback secret: each file's one line, when given.
  for (auto [file, into] :
       {std::pair{&token_file, &o.auth_token}, std::pair{&callback_secret_file, &o.callback_secret}}) {
    if (file->empty()) continue;
    absl::StatusOr<std::string> secret = meshsmooth::ReadTokenFile(*file);
    if (!secret.ok()) {
      meshsmooth::server::LogEvent(o.log_format, "error", "start_failed", std::string(secret.status().message()));
      return 1;
    }
    *into = *std::move(secret);
  }

  // Block the shutdown signals before gRPC starts its threads, then wait for them on one
  // thread of our own: a handler installed after BuildAndStart is ignored.
  meshsmooth::BlockShutdownSignals();

  using meshsmooth::server::JsonLine;
  using meshsmooth::server::LogEvent;
  meshsmooth::server::RouteGrpcLog(o.log_format);
  auto server = meshsmooth::server::Server::Start(o);
  if (!server.ok()) {
    LogEvent(o.log_format, "error", "start_failed", std::string(server.status().message()));
    return 1;
  }
  const auto host = [](const std::string& address) { return address.substr(0, address.rfind(':')); };
  if ((*server)->metrics_port() != 0) {
    std::printf("meshsmoothd metrics on %s:%d\n", host(o.metrics_listen).c_str(), (*server)->metrics_port());
  }
  std::printf("meshsmoothd listening on %s:%d\n", host(o.listen).c_str(), (*server)->port());
  std::fflush(stdout);
  if (o.log_format == meshsmooth::server::LogFormat::kJson) {
    LogEvent(o.log_format, "info", "listening", absl::StrCat("listening on ", host(o.listen), ":", (*server)->port()),
             [&](JsonLine& l) {
               l.Int("port", (*server)->port());
               l.Int("metrics_port", (*server)->metrics_port());
             });
  }

  const int sig = meshsmooth::WaitForShutdownSignal();
  const char* sig_name = sig == SIGINT ? "SIGINT" : "SIGTERM";
  LogEvent(o.log_format, "info", "shutdown",
           absl::StrFormat("%s, shutting down (grace %g s)", sig_name, o.grace_seconds), [&](JsonLine& l) {
             l.Str("signal", sig_name);
             l.Num("grace_seconds", o.grace_seconds);
           });
  // An orchestrator kills a replica that overruns its grace: exit first, by grace + 1 s, even if
  // a cancelled job is inside a step that cannot stop sooner (Draco's decoder, say).
  std::thread([format = o.log_format, grace = o.grace_seconds] {
    std::this_thread::sleep_for(std::chrono::duration<double>(grace + 0.9));
    LogEvent(format, "error", "shutdown_overrun",
             absl::StrFormat("still stopping %g s after the signal; exiting now", grace + 0.9));
    std::fflush(stdout);
    std::_Exit(1);  // no leak check: a job's step may still hold its memory
  }).detach();
  const int cut = (*server)->Shutdown();
  if (cut > 0) {
    LogEvent(o.log_format, "warning", "stopped", absl::StrCat("stopped; the grace cut ", cut, " running job(s)"),
             [&](JsonLine& l) { l.Int("jobs_cut", cut); });
    ExitWithoutTeardown(1);
  }
  LogEvent(o.log_format, "info", "stopped", "stopped", [](JsonLine& l) { l.Int("jobs_cut", 0); });
  // Every call has ended and every log line is written: leave now. Returning would destroy the
  // grpc::Server, whose last library reference runs gRPC's teardown; that joins an executor
  // thread which may sit in a TCP write's backup poller for up to 10 s (docs/decisions.md).
  ExitWithoutTeardown(0);
}
