#include "server/metrics.h"

#include <dirent.h>
#include <unistd.h>

#include <array>
#include <fstream>
#include <mutex>
#include <sstream>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "prometheus/collectable.h"
#include "prometheus/counter.h"
#include "prometheus/exposer.h"
#include "prometheus/family.h"
#include "prometheus/histogram.h"
#include "prometheus/metric_family.h"
#include "prometheus/registry.h"

namespace meshsmooth::server {

std::string_view RefusalName(Refusal reason) {
  switch (reason) {
    case Refusal::kQueueFull:
      return "queue_full";
    case Refusal::kQueueWait:
      return "queue_wait";
    case Refusal::kMemoryBudget:
      return "memory_budget";
    case Refusal::kUploadTooLarge:
      return "upload_too_large";
    case Refusal::kChunkTooLarge:
      return "chunk_too_large";
    case Refusal::kTooManyCalls:
      return "too_many_calls";
    case Refusal::kUploadIdle:
      return "upload_idle";
    case Refusal::kShuttingDown:
      return "shutting_down";
    case Refusal::kUnauthenticated:
      return "unauthenticated";
    case Refusal::kInvalidRequest:
      return "invalid_request";
    case Refusal::kJobTooLarge:
      return "job_too_large";
  }
  return "unknown";
}

namespace {

class Discard final : public ServiceMetrics {
 public:
  void JobEnded(const JobReport&, const JobParams&) override {}
  void Refused(Refusal) override {}
  void UploadReceived(int64_t) override {}
  void JobUploadReceived(int64_t) override {}
};

// The first line of `path` that starts with `key`, without it; empty when there is none.
std::string LineAfter(const std::string& path, std::string_view key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.compare(0, key.size(), key) == 0) return line.substr(key.size());
  }
  return {};
}

}  // namespace

ServiceMetrics& NoMetrics() {
  static Discard discard;
  return discard;
}

std::optional<ProcessSamples> ReadProcessSamples(const std::string& proc, const std::string& proc_stat) {
  std::ifstream stat_file(proc + "/stat");
  std::string stat((std::istreambuf_iterator<char>(stat_file)), std::istreambuf_iterator<char>());
  // The command name, field 2, may hold spaces and parentheses: the fields after it follow the
  // last ')'. Field n of proc(5) is then fields[n - 3].
  const size_t paren = stat.rfind(')');
  if (paren == std::string::npos) return std::nullopt;
  std::istringstream rest(stat.substr(paren + 1));
  std::vector<std::string> fields;
  for (std::string f; rest >> f;) fields.push_back(f);
  if (fields.size() < 22) return std::nullopt;
  const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
  const double page = static_cast<double>(sysconf(_SC_PAGESIZE));
  ProcessSamples s;
  try {
    s.cpu_seconds = (std::stod(fields[11]) + std::stod(fields[12])) / ticks;  // utime + stime
    const double boot = std::stod(LineAfter(proc_stat, "btime "));
    s.start_time_seconds = boot + std::stod(fields[19]) / ticks;
    s.virtual_memory_bytes = std::stod(fields[20]);
    s.resident_memory_bytes = std::stod(fields[21]) * page;
    // "Max open files            1024                 1048576              files"
    std::istringstream limits(LineAfter(proc + "/limits", "Max open files"));
    std::string soft;
    limits >> soft;
    s.max_fds = soft == "unlimited" ? -1.0 : std::stod(soft);
  } catch (const std::exception&) {  // std::stod: not a number
    return std::nullopt;
  }
  if (DIR* dir = opendir((proc + "/fd").c_str())) {
    int64_t n = 0;
    while (const dirent* e = readdir(dir)) n += e->d_name[0] != '.';
    closedir(dir);
    s.open_fds = static_cast<double>(n - 1);  // not the descriptor this count reads through
  }
  return s;
}

namespace {

using prometheus::ClientMetric;
using prometheus::MetricFamily;
using prometheus::MetricType;

MetricFamily Single(std::string name, std::string help, MetricType type, double value) {
  MetricFamily f{std::move(name), std::move(help), type, {}};
  ClientMetric m;
  if (type == MetricType::Counter) {
    m.counter.value = value;
  } else {
    m.gauge.value = value;
  }
  f.metric.push_back(std::move(m));
  return f;
}

// The job store's queue: the whole store's (the same from every replica that shares it: take the
// max, not the sum, across replicas), and this process's lease takeovers.
void AddJobStore(const ServiceGauges& g, std::vector<MetricFamily>& out) {
  out.push_back(Single("meshsmooth_job_store_queue_depth", "Jobs QUEUED in the job store (the whole store).",
                       MetricType::Gauge, static_cast<double>(g.stored_jobs[v1::JOB_STATE_QUEUED])));
  out.push_back(Single("meshsmooth_job_store_oldest_queued_seconds",
                       "Age of the oldest QUEUED job in the job store; 0 when none is queued.", MetricType::Gauge,
                       g.oldest_queued_seconds));
  MetricFamily by_state{
      "meshsmooth_job_store_jobs", "Jobs in the job store by state (the whole store).", MetricType::Gauge, {}};
  for (int s = v1::JOB_STATE_QUEUED; s <= v1::JOB_STATE_CANCELLED; ++s) {
    ClientMetric m;
    m.label.push_back({"state", absl::AsciiStrToLower(v1::JobState_Name(static_cast<v1::JobState>(s)).substr(10))});
    m.gauge.value = static_cast<double>(g.stored_jobs[s]);
    by_state.metric.push_back(std::move(m));
  }
  out.push_back(std::move(by_state));
  out.push_back(Single("meshsmooth_job_lease_takeovers_total",
                       "Jobs this process claimed after the lease of the replica that ran them had run out.",
                       MetricType::Counter, static_cast<double>(g.lease_takeovers)));
}

// The gauges read at each scrape: the service's state and the process's CPU and memory.
class ScrapeCollector final : public prometheus::Collectable {
 public:
  void SetSource(std::function<ServiceGauges()> source) {
    std::lock_guard<std::mutex> lock(mu_);
    source_ = std::move(source);
  }

  std::vector<MetricFamily> Collect() const override {
    std::vector<MetricFamily> out;
    {
      // Held while the service is read: SetSource(nullptr) returns only after this scrape.
      std::lock_guard<std::mutex> lock(mu_);
      if (source_) {
        const ServiceGauges g = source_();
        out.push_back(Single("meshsmooth_queue_depth", "Jobs waiting for a worker.", MetricType::Gauge,
                             static_cast<double>(g.queued_jobs)));
        out.push_back(Single("meshsmooth_jobs_running", "Jobs on a worker.", MetricType::Gauge,
                             static_cast<double>(g.running_jobs)));
        out.push_back(Single("meshsmooth_buffered_bytes",
                             "Bytes held by uploads in flight and queued jobs (against --max-buffered-bytes).",
                             MetricType::Gauge, static_cast<double>(g.buffered_bytes)));
        out.push_back(Single("meshsmooth_buffered_bytes_limit", "--max-buffered-bytes in effect.", MetricType::Gauge,
                             static_cast<double>(g.buffered_bytes_limit)));
        out.push_back(Single("meshsmooth_workers", "Jobs smoothed at once (--workers in effect).", MetricType::Gauge,
                             static_cast<double>(g.workers)));
        out.push_back(Single("meshsmooth_queue_capacity", "Jobs that may wait for a worker (--queue-depth).",
                             MetricType::Gauge, static_cast<double>(g.queue_capacity)));
        if (g.job_store) AddJobStore(g, out);
      }
    }
    if (const std::optional<ProcessSamples> p = ReadProcessSamples()) {
      out.push_back(Single("process_cpu_seconds_total", "Total user and system CPU time spent in seconds.",
                           MetricType::Counter, p->cpu_seconds));
      out.push_back(Single("process_resident_memory_bytes", "Resident memory size in bytes.", MetricType::Gauge,
                           p->resident_memory_bytes));
      out.push_back(Single("process_virtual_memory_bytes", "Virtual memory size in bytes.", MetricType::Gauge,
                           p->virtual_memory_bytes));
      out.push_back(Single("process_start_time_seconds", "Start time of the process since unix epoch in seconds.",
                           MetricType::Gauge, p->start_time_seconds));
      out.push_back(Single("process_open_fds", "Number of open file descriptors.", MetricType::Gauge, p->open_fds));
      out.push_back(
          Single("process_max_fds", "Maximum number of open file descriptors.", MetricType::Gauge, p->max_fds));
    }
    return out;
  }

 private:
  mutable std::mutex mu_;
  std::function<ServiceGauges()> source_;
};

// Job steps from a fraction of a millisecond (a tiny mesh's decode) to the 600 s job limit.
const prometheus::Histogram::BucketBoundaries kStepBuckets = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5,
                                                              1,     2.5,    5,     10,   25,    60,   120, 300,  600};
// Automatic stopping runs 1 .. kMaxAutoIterations (1,000) iterations.
const prometheus::Histogram::BucketBoundaries kIterationBuckets = {1, 2, 5, 10, 20, 50, 100, 200, 500, 1000};

// The counters and histograms, updated as events arrive.
class PrometheusEvents final : public ServiceMetrics {
 public:
  explicit PrometheusEvents(prometheus::Registry& r)
      : jobs_(prometheus::BuildCounter()
                  .Name("meshsmooth_jobs_total")
                  .Help("Jobs a worker took, by the flow that ran (or was asked for) and the gRPC status they "
                        "ended with.")
                  .Register(r)),
        refusals_(prometheus::BuildCounter()
                      .Name("meshsmooth_refusals_total")
                      .Help("Smooth calls ended before their job ran, or while it waited for a worker, by reason.")
                      .Register(r)),
        auto_stops_(prometheus::BuildCounter()
                        .Name("meshsmooth_auto_stops_total")
                        .Help("Automatic-iteration jobs that succeeded, by why their run stopped.")
                        .Register(r)),
        vertices_(prometheus::BuildCounter()
                      .Name("meshsmooth_vertices_processed_total")
                      .Help("Vertices of the meshes of the jobs that succeeded.")
                      .Register(r)
                      .Add({})),
        iterations_(prometheus::BuildCounter()
                        .Name("meshsmooth_iterations_total")
                        .Help("Smoothing iterations run, by every job.")
                        .Register(r)
                        .Add({})),
        upload_bytes_(prometheus::BuildCounter()
                          .Name("meshsmooth_upload_bytes_total")
                          .Help("Draco bytes received in mesh chunks.")
                          .Register(r)
                          .Add({})),
        job_upload_bytes_(
            prometheus::BuildCounter()
                .Name("meshsmooth_job_upload_bytes_total")
                .Help("Draco bytes received in Submit chunks (kept jobs' uploads), resent bytes included.")
                .Register(r)
                .Add({})),
        auto_iterations_(prometheus::BuildHistogram()
                             .Name("meshsmooth_auto_iterations")
                             .Help("Iterations automatic stopping ran, by job that succeeded.")
                             .Register(r)
                             .Add({}, kIterationBuckets)) {
    auto& steps = prometheus::BuildHistogram()
                      .Name("meshsmooth_job_duration_seconds")
                      .Help(
                          "Seconds of each step of a job: waiting for a worker (queue), decoding and validating "
                          "(decode), smoothing (smooth), detecting features and encoding (encode).")
                      .Register(r);
    for (int i = 0; i < 4; ++i) {
      static constexpr std::array<const char*, 4> kSteps = {"queue", "decode", "smooth", "encode"};
      steps_[i] = &steps.Add({{"step", kSteps[i]}}, kStepBuckets);
    }
    for (int i = 0; i < kRefusalCount; ++i) {
      refused_[i] = &refusals_.Add({{"reason", std::string(RefusalName(static_cast<Refusal>(i)))}});
    }
  }

  void JobEnded(const JobReport& report, const JobParams& params) override {
    jobs_.Add({{"flow", std::string(JobFlowName(report, params))}, {"status", report.status}}).Increment();
    // A step that ran took some time; one that did not run kept its 0.
    const double seconds[4] = {report.queue_seconds, report.decode_seconds, report.smooth_seconds,
                               report.encode_seconds};
    for (int i = 0; i < 4; ++i) {
      if (seconds[i] > 0.0) steps_[i]->Observe(seconds[i]);
    }
    iterations_.Increment(report.flow.iterations_run);
    if (report.status != "OK") return;
    vertices_.Increment(static_cast<double>(report.vertices));
    if (params.flow.iterations == kAutoIterations) {
      auto_iterations_.Observe(report.flow.iterations_run);
      auto_stops_.Add({{"reason", std::string(StopReasonName(report.flow.stop_reason))}}).Increment();
    }
  }

  void Refused(Refusal reason) override { refused_[static_cast<int>(reason)]->Increment(); }

  void UploadReceived(int64_t bytes) override { upload_bytes_.Increment(static_cast<double>(bytes)); }
  void JobUploadReceived(int64_t bytes) override { job_upload_bytes_.Increment(static_cast<double>(bytes)); }

 private:
  prometheus::Family<prometheus::Counter>& jobs_;
  prometheus::Family<prometheus::Counter>& refusals_;
  prometheus::Family<prometheus::Counter>& auto_stops_;
  prometheus::Counter& vertices_;
  prometheus::Counter& iterations_;
  prometheus::Counter& upload_bytes_;
  prometheus::Counter& job_upload_bytes_;
  prometheus::Histogram& auto_iterations_;
  std::array<prometheus::Histogram*, 4> steps_{};
  std::array<prometheus::Counter*, kRefusalCount> refused_{};
};

}  // namespace

struct MetricsExporter::State {
  std::shared_ptr<prometheus::Registry> registry = std::make_shared<prometheus::Registry>();
  std::unique_ptr<PrometheusEvents> events;
  std::shared_ptr<ScrapeCollector> scrape;
  std::unique_ptr<prometheus::Exposer> exposer;
};

absl::StatusOr<std::unique_ptr<MetricsExporter>> MetricsExporter::Start(const std::string& listen) {
  auto state = std::make_unique<State>();
  state->events = std::make_unique<PrometheusEvents>(*state->registry);
  state->scrape = std::make_shared<ScrapeCollector>();
  try {
    // One thread: a scrape is a few kilobytes and Prometheus sends one at a time.
    state->exposer = std::make_unique<prometheus::Exposer>(listen, 1);
  } catch (const std::exception& e) {  // civetweb could not bind
    return absl::FailedPreconditionError(absl::StrCat("cannot serve metrics on ", listen, ": ", e.what()));
  }
  if (state->exposer->GetListeningPorts().empty()) {
    return absl::FailedPreconditionError(absl::StrCat("cannot serve metrics on ", listen));
  }
  state->exposer->RegisterCollectable(state->registry);
  state->exposer->RegisterCollectable(state->scrape);
  return std::unique_ptr<MetricsExporter>(new MetricsExporter(std::move(state)));
}

MetricsExporter::MetricsExporter(std::unique_ptr<State> state) : state_(std::move(state)) {}

MetricsExporter::~MetricsExporter() { state_->exposer.reset(); }

int MetricsExporter::port() const { return state_->exposer->GetListeningPorts().front(); }

ServiceMetrics& MetricsExporter::events() { return *state_->events; }

void MetricsExporter::SetGaugeSource(std::function<ServiceGauges()> source) {
  state_->scrape->SetSource(std::move(source));
}

}  // namespace meshsmooth::server
