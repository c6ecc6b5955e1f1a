#include "client/report.h"

#include <unistd.h>

#include <cstdio>
#include <sstream>
#include <string>

namespace meshsmooth::client {
namespace {

// "A | B" for an enumeration, "default D, range [MIN, MAX)" otherwise.
std::string Range(const v1::ParameterInfo& p) {
  if (p.choices_size() > 0) {
    std::string list;
    for (const auto& x : p.choices()) list += (list.empty() ? "" : " | ") + x;
    return list;
  }
  std::ostringstream r;
  r << "default " << p.default_value() << ", range " << (p.min_exclusive() ? "(" : "[") << p.min_value() << ", "
    << p.max_value() << (p.max_exclusive() ? ")" : "]");
  return r.str();
}

}  // namespace

ProgressPrinter::ProgressPrinter(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}

void ProgressPrinter::operator()(const v1::Progress& p) {
  if (quiet_) return;
  if (p.phase() != v1::PROGRESS_PHASE_SMOOTHING && p.phase() != v1::PROGRESS_PHASE_UNSPECIFIED) {
    if (bar_shown_) std::fprintf(stderr, "\n");
    bar_shown_ = false;
    switch (p.phase()) {
      case v1::PROGRESS_PHASE_NOISE_ESTIMATE:
        std::fprintf(stderr, "reading the noise\n");
        break;
      case v1::PROGRESS_PHASE_CHOOSING:
        std::fprintf(stderr, "choosing the flow and the count: trying %s\n", p.flow().c_str());
        break;
      case v1::PROGRESS_PHASE_ENHANCING:
        std::fprintf(stderr, "enhancing\n");
        break;
      default:
        std::fprintf(stderr, "writing the result (%.2fs)\n", p.elapsed_seconds());
        break;
    }
    return;
  }
  if (p.iteration() == 1 || p.flow() != smoothing_flow_) {
    if (bar_shown_) std::fprintf(stderr, "\n");
    bar_shown_ = false;
    smoothing_flow_ = p.flow();
    if (!smoothing_flow_.empty()) std::fprintf(stderr, "smoothing with %s\n", smoothing_flow_.c_str());
  }
  if (p.total() == 0) {  // automatic stopping: no total to count down to
    std::fprintf(stderr,
                 tty_ ? "\riteration %u (automatic stop)  max move %.3g  mean %.3g  elapsed %.1fs "
                      : "iteration %u (automatic stop) max move %.6g mean %.6g elapsed %.2fs\n",
                 p.iteration(), p.max_displacement(), p.mean_displacement(), p.elapsed_seconds());
    bar_shown_ = bar_shown_ || tty_;
    return;
  }
  const double frac = p.total() > 0 ? static_cast<double>(p.iteration()) / p.total() : 1.0;
  const double eta = frac > 0 ? p.elapsed_seconds() * (1.0 - frac) / frac : 0.0;
  // No move measured: iterations run at once, as one polynomial (the proto's Progress), or none
  // moved.
  const bool no_move = p.moved_share() == 0.0 && p.max_displacement() == 0.0;
  if (tty_) {
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(frac * kWidth);
    if (no_move) {
      std::fprintf(stderr, "\r[%s%s] %u/%u  ETA %.1fs                         ", std::string(filled, '#').c_str(),
                   std::string(kWidth - filled, '.').c_str(), p.iteration(), p.total(), eta);
      bar_shown_ = true;
      return;
    }
    std::fprintf(stderr, "\r[%s%s] %u/%u  max move %.3g  mean %.3g  ETA %.1fs ", std::string(filled, '#').c_str(),
                 std::string(kWidth - filled, '.').c_str(), p.iteration(), p.total(), p.max_displacement(),
                 p.mean_displacement(), eta);
    bar_shown_ = true;
  } else if (no_move) {
    std::fprintf(stderr, "iteration %u/%u elapsed %.2fs\n", p.iteration(), p.total(), p.elapsed_seconds());
  } else {
    std::fprintf(stderr, "iteration %u/%u max move %.6g mean %.6g moved %.1f%% elapsed %.2fs\n", p.iteration(),
                 p.total(), p.max_displacement(), p.mean_displacement(), 100.0 * p.moved_share(), p.elapsed_seconds());
  }
}

void ProgressPrinter::Done() {
  if (bar_shown_) std::fprintf(stderr, "\n");
}

void PrintRetry(const std::string& prefix, int retry, const absl::Status& status, std::chrono::milliseconds wait) {
  std::fprintf(stderr, "meshsmooth: %sattempt %d failed (%s: %s); retrying in %.1f s\n", prefix.c_str(), retry,
               std::string(absl::StatusCodeToString(status.code())).c_str(), std::string(status.message()).c_str(),
               static_cast<double>(wait.count()) / 1000.0);
}

void PrintSummary(const v1::Summary& s) {
  const v1::MeshMetrics &a = s.before(), &b = s.after();
  const v1::EffectiveParameters& p = s.parameters();
  if (p.has_enhance()) {
    std::printf("job %s: enhanced (%s), gain %g below a detail scale of %g (%.3g mean edge lengths)\n",
                s.job_id().c_str(),
                p.enhance().method() == v1::ENHANCE_METHOD_INVERTED_FLOW ? "inverted flow" : "screened Poisson",
                p.enhance().gain(), p.enhance().detail_scale(), p.enhance().detail_scale_h());
    if (p.enhance_held_back() > 0) {
      std::printf("held back at %lld vertices, where faces would turn over\n",
                  static_cast<long long>(p.enhance_held_back()));
    }
    if (p.iterations_run() > 0) {
      std::printf(
          "after smoothing the noisy input: %s, %u iterations (stopped by %s), noise estimate %.4f mean edges\n",
          p.flow().c_str(), p.iterations_run(), p.stop_reason().c_str(), p.noise_estimate());
    }
  } else if (p.iterations_requested() == 0) {
    std::printf("job %s: %s, %u iterations (automatic: stopped by %s), step %g (effective %g)\n", s.job_id().c_str(),
                p.flow().c_str(), p.iterations_run(), p.stop_reason().c_str(), p.step(), p.effective_step());
    std::printf(
        "noise estimate %.4f mean edges (%.4f with fine detail taken out); vertices moved %.4f mean edges (RMS along "
        "their normals)\n",
        p.noise_estimate(), p.noise_estimate_detail_free(), p.noise_removed());
  } else {
    std::printf("job %s: %s, %u of %u iterations (stopped by %s), step %g (effective %g)\n", s.job_id().c_str(),
                p.flow().c_str(), p.iterations_run(), p.iterations_requested(), p.stop_reason().c_str(), p.step(),
                p.effective_step());
  }
  if (p.boundary() == v1::BOUNDARY_MODE_CURVE) std::printf("boundary vertices moved too (boundary: curve)\n");
  if (p.outliers_moved() > 0) {
    std::printf("%lld outliers (vertices thrown off the surface) moved back onto it first\n",
                static_cast<long long>(p.outliers_moved()));
  }
  std::printf("%-28s %14s %14s\n", "", "before", "after");
  std::printf("%-28s %14.6g %14.6g\n", "area", a.area(), b.area());
  std::printf("%-28s %14.6g %14.6g\n", "signed volume", a.signed_volume(), b.signed_volume());
  std::printf("%-28s %14.6g %14.6g\n", "edge length mean", a.edge_length_mean(), b.edge_length_mean());
  std::printf("%-28s %14.4f %14.4f\n", "edge length CV", a.edge_length_cv(), b.edge_length_cv());
  std::printf("%-28s %14.2f %14.2f\n", "min angle (deg)", a.min_angle_deg(), b.min_angle_deg());
  std::printf("%-28s %13.2f%% %13.2f%%\n", "angles below 10 deg", 100 * a.share_angles_below_10deg(),
              100 * b.share_angles_below_10deg());
  std::printf("displacement RMS %.6g, max %.6g; flipped normals %lld\n", s.rms_displacement(), s.max_displacement(),
              static_cast<long long>(s.flipped_normals()));
  if (p.max_displacement() > 0.0) {
    std::printf("bound on displacement %.6g: %lld vertices at it (moved 99.9%% of it or more)\n", p.max_displacement(),
                static_cast<long long>(s.vertices_at_bound()));
  }
  if (s.has_features()) {
    std::printf("features: %lld ridge and %lld ravine vertices of %lld classified (%.3fs)\n",
                static_cast<long long>(s.features().ridge_vertices()),
                static_cast<long long>(s.features().ravine_vertices()),
                static_cast<long long>(s.features().classified_vertices()), s.features().detect_seconds());
  }
  const v1::Timings& t = s.timings();
  std::printf("time: decode %.3fs, queue %.3fs, smooth %.3fs, encode %.3fs, total %.3fs", t.decode_seconds(),
              t.queue_seconds(), t.smooth_seconds(), t.encode_seconds(), t.total_seconds());
  // The local run hands its result over in memory: no bytes to count.
  if (s.result_bytes() > 0) std::printf("; result %llu bytes", static_cast<unsigned long long>(s.result_bytes()));
  std::printf("\n");
}

std::string OneLineSummary(const v1::Summary& s) {
  const v1::EffectiveParameters& p = s.parameters();
  char line[512];
  if (p.has_enhance()) {
    std::snprintf(line, sizeof line, "enhanced, gain %g below %g mesh units%s", p.enhance().gain(),
                  p.enhance().detail_scale(), p.iterations_run() > 0 ? " (smoothed first)" : "");
  } else if (p.iterations_requested() == 0) {
    std::snprintf(line, sizeof line, "%s, %u iterations (automatic: stopped by %s)", p.flow().c_str(),
                  p.iterations_run(), p.stop_reason().c_str());
  } else {
    std::snprintf(line, sizeof line, "%s, %u of %u iterations (stopped by %s)", p.flow().c_str(), p.iterations_run(),
                  p.iterations_requested(), p.stop_reason().c_str());
  }
  char moved[128];
  std::snprintf(moved, sizeof moved, "; displacement RMS %.6g, max %.6g", s.rms_displacement(), s.max_displacement());
  return std::string(line) + moved;
}

void PrintFlows(const v1::ListFlowsResponse& flows) {
  for (const v1::FlowInfo& f : flows.flows()) {
    std::printf("%s  (paper: %s)\n  %s\n", f.name().c_str(), f.equations().c_str(), f.description().c_str());
    for (const v1::ParameterInfo& p : f.parameters()) {
      std::printf("    %-18s %s; %s\n", p.name().c_str(), p.description().c_str(), Range(p).c_str());
    }
    for (const std::string& c : f.constraints()) std::printf("    and %s\n", c.c_str());
  }
  std::printf("every flow:\n");
  for (const v1::ParameterInfo& p : flows.common_parameters()) {
    std::printf("    %-24s %s; %s\n", p.name().c_str(), p.description().c_str(), Range(p).c_str());
  }
  std::printf("this server allows at most %u iterations\n", flows.max_iterations());
  if (flows.enhance_parameters_size() > 0) {
    std::printf("enhancement (meshsmooth enhance; JobSpec.enhance), the inverse of smoothing:\n");
    for (const v1::ParameterInfo& p : flows.enhance_parameters()) {
      std::printf("    %-24s %s; %s\n", p.name().c_str(), p.description().c_str(), Range(p).c_str());
    }
  }
}

}  // namespace meshsmooth::client
