// meshsmooth_load: a closed-loop load on a running service, for throughput and latency.
//
//   build/bench/meshsmooth_load --target T [--clients 8] [--jobs 200] [--warmup 1]
//                               [--input builtin:noisy-sphere] [--flow F] [--iterations N]
//
// Each client is a thread with a channel of its own (as separate client processes would have),
// round-robin over the addresses of T (`ipv4:a:p,b:p`, `dns:///name:port`, or one HOST:PORT,
// e.g. a proxy's), sending the same job back to back until --jobs jobs are done; the first
// --warmup jobs of each client (connection set-up) are not counted. A job's latency is the
// client's wall time from its first message to the summary. Prints one line:
//   jobs=N clients=C seconds=S jobs_per_second=X p50_ms=A p99_ms=B mean_ms=M failed=F
// and exits 1 if a job failed. bench/replicas.py runs it against replicas with and without nginx.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "base/huge_pages.h"
#include "client/inputs.h"
#include "client/smooth_client.h"
#include "core/io/draco_codec.h"
#include "core/vec3.h"
#include "grpcpp/grpcpp.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Options {
  std::string target;
  int clients = 8;
  int jobs = 200;
  int warmup = 1;
  std::string input = "builtin:noisy-sphere";
  std::string flow;
  int iterations = 0;  // 0 = automatic stopping, the service's default
};

// The p-th percentile (0..100) of sorted values, nearest rank.
double Percentile(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0.0;
  const size_t rank = static_cast<size_t>(std::max(1.0, std::ceil(p / 100.0 * sorted.size())));
  return sorted[std::min(rank, sorted.size()) - 1];
}

int Usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s --target T [--clients 8] [--jobs 200] [--warmup 1] [--input builtin:noisy-sphere] "
               "[--flow F] [--iterations N]\n",
               argv0);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  meshsmooth::UseHugePagesForLargeBuffers(argv);  // first: may re-execute the program
  using namespace meshsmooth;
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--target" && has_value)
      o.target = argv[++i];
    else if (a == "--clients" && has_value)
      o.clients = std::max(1, std::atoi(argv[++i]));
    else if (a == "--jobs" && has_value)
      o.jobs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--warmup" && has_value)
      o.warmup = std::max(0, std::atoi(argv[++i]));
    else if (a == "--input" && has_value)
      o.input = argv[++i];
    else if (a == "--flow" && has_value)
      o.flow = argv[++i];
    else if (a == "--iterations" && has_value)
      o.iterations = std::max(0, std::atoi(argv[++i]));
    else
      return Usage(argv[0]);
  }
  if (o.target.empty()) return Usage(argv[0]);

  absl::StatusOr<Mesh> mesh = client::LoadInput(o.input);
  if (!mesh.ok()) {
    std::fprintf(stderr, "meshsmooth_load: %s\n", std::string(mesh.status().message()).c_str());
    return 2;
  }
  for (Vec3& p : mesh->positions) p = RoundToFloat(p);
  absl::StatusOr<std::string> draco = EncodeDraco(*mesh);
  if (!draco.ok()) {
    std::fprintf(stderr, "meshsmooth_load: %s\n", std::string(draco.status().message()).c_str());
    return 2;
  }
  v1::JobSpec spec;
  if (!o.flow.empty()) spec.set_flow(o.flow);
  spec.set_iterations(static_cast<uint32_t>(o.iterations));

  std::atomic<int> next{0}, failed{0};
  std::mutex mu;
  std::vector<double> latencies;  // ms, counted jobs only
  Clock::time_point first_counted = Clock::time_point::max(), last_done{};
  std::string first_error;
  auto client = [&](int id) {
    grpc::ChannelArguments args;
    args.SetLoadBalancingPolicyName("round_robin");
    args.SetInt("meshsmooth_load.client", id);  // a distinct argument: a connection of its own
    auto stub =
        v1::MeshSmoother::NewStub(grpc::CreateCustomChannel(o.target, grpc::InsecureChannelCredentials(), args));
    for (int done = 0;; ++done) {
      const bool counted = done >= o.warmup;
      if (counted && next.fetch_add(1) >= o.jobs) return;
      grpc::ClientContext ctx;
      ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::minutes(2));
      // A connection attempt that fails once (seen twice in ~100 runs on loopback, every job of
      // the run failing at once with "connections to all backends failing") waits for the
      // reconnection instead of failing the run: the load measures jobs, not connects.
      ctx.set_wait_for_ready(true);
      const Clock::time_point t0 = Clock::now();
      absl::StatusOr<client::SmoothOutcome> out = client::CallSmooth(*stub, ctx, spec, *draco);
      const Clock::time_point t1 = Clock::now();
      std::lock_guard<std::mutex> lock(mu);
      if (!out.ok()) {
        ++failed;
        if (first_error.empty()) first_error = std::string(out.status().message());
      }
      if (counted) {
        latencies.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        first_counted = std::min(first_counted, t0);
        last_done = std::max(last_done, t1);
      }
    }
  };
  std::vector<std::thread> threads;
  for (int c = 0; c < o.clients; ++c) threads.emplace_back(client, c);
  for (std::thread& t : threads) t.join();

  std::sort(latencies.begin(), latencies.end());
  double mean = 0.0;
  for (double l : latencies) mean += l / latencies.size();
  const double seconds = std::chrono::duration<double>(last_done - first_counted).count();
  std::printf("jobs=%zu clients=%d seconds=%.3f jobs_per_second=%.2f p50_ms=%.2f p99_ms=%.2f mean_ms=%.2f failed=%d\n",
              latencies.size(), o.clients, seconds, latencies.size() / seconds, Percentile(latencies, 50),
              Percentile(latencies, 99), mean, failed.load());
  if (failed.load() > 0) std::fprintf(stderr, "meshsmooth_load: first failure: %s\n", first_error.c_str());
  return failed.load() > 0 ? 1 : 0;
}
