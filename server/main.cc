// meshsmoothd: the meshsmooth gRPC server.
//
// Prints "meshsmoothd listening on HOST:PORT" on stdout once it serves (with --listen
// HOST:0 the port is the one the system picked). SIGINT/SIGTERM shut it down gracefully.
// Exit codes: 0 after a clean shutdown; 1 when it cannot start, or when a shutdown had to be cut
// short at grace + 1 s; 2 for a bad command line.
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <thread>

#include "CLI/CLI.hpp"
#include "absl/strings/str_cat.h"
#include "base/huge_pages.h"
#include "base/shutdown_signals.h"
#include "core/io/file_bytes.h"
#include "server/admission.h"
#include "server/server.h"

int main(int argc, char** argv) {
  meshsmooth::UseHugePagesForLargeBuffers(argv);  // first: may re-execute the program
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
      "--quiet", [&o](int64_t) { o.log_jobs = false; }, "no per-job log lines");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (!token_file.empty()) {
    absl::StatusOr<std::string> token = meshsmooth::ReadTokenFile(token_file);
    if (!token.ok()) {
      std::cerr << "meshsmoothd: " << token.status().message() << "\n";
      return 1;
    }
    o.auth_token = *std::move(token);
  }

  // Block the shutdown signals before gRPC starts its threads, then wait for them on one
  // thread of our own: a handler installed after BuildAndStart is ignored.
  meshsmooth::BlockShutdownSignals();

  auto server = meshsmooth::server::Server::Start(o);
  if (!server.ok()) {
    std::cerr << "meshsmoothd: " << server.status().message() << "\n";
    return 1;
  }
  const std::string host = o.listen.substr(0, o.listen.rfind(':'));
  std::printf("meshsmoothd listening on %s:%d\n", host.c_str(), (*server)->port());
  std::fflush(stdout);

  const int sig = meshsmooth::WaitForShutdownSignal();
  std::fprintf(stderr, "meshsmoothd: %s, shutting down (grace %g s)\n", sig == SIGINT ? "SIGINT" : "SIGTERM",
               o.grace_seconds);
  // An orchestrator kills a replica that overruns its grace: exit first, by grace + 1 s, even if
  // a cancelled job is inside a step that cannot stop sooner (Draco's decoder, say).
  std::thread([grace = o.grace_seconds] {
    std::this_thread::sleep_for(std::chrono::duration<double>(grace + 0.9));
    std::fprintf(stderr, "meshsmoothd: still stopping %g s after the signal; exiting now\n", grace + 0.9);
    std::fflush(stderr);
    std::_Exit(1);
  }).detach();
  (*server)->Shutdown();
  std::fprintf(stderr, "meshsmoothd: stopped\n");
  return 0;
}
