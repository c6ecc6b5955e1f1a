#include "server/log.h"

#include <cmath>
#include <cstdio>
#include <ctime>

#include <chrono>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/io/formats.h"
#include "grpc/support/log.h"

namespace meshsmooth::server {
namespace {

std::string NowRfc3339() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t secs = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc{};
  gmtime_r(&secs, &utc);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &utc);
  return absl::StrFormat("%s.%03dZ", buf, static_cast<int>(ms));
}

// Length of the valid UTF-8 sequence at s[i], or 0 when there is none.
size_t Utf8Length(std::string_view s, size_t i) {
  const auto c = static_cast<unsigned char>(s[i]);
  size_t n = c >= 0xF0 && c <= 0xF4 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 && c < 0xE0 ? 2 : 0;
  if (n == 0 || i + n > s.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    if ((static_cast<unsigned char>(s[i + k]) & 0xC0) != 0x80) return 0;
  }
  return n;
}

void WriteLine(std::string line) {
  line.push_back('\n');
  // stderr is unbuffered: one fwrite is one write(2), so concurrent entries do not interleave.
  std::fwrite(line.data(), 1, line.size(), stderr);
}

std::string_view JobLevel(const std::string& status) {
  if (status == "OK") return "info";
  if (status == "INTERNAL" || status == "UNKNOWN" || status == "DATA_LOSS") return "error";
  return "warning";
}

// "RESOURCE_EXHAUSTED": the code's name (gRPC's and absl's codes share their numbers).
std::string GrpcCodeName(grpc::StatusCode code) {
  return absl::StatusCodeToString(static_cast<absl::StatusCode>(code));
}

void GrpcLogToJson(gpr_log_func_args* args) {
  const std::string_view level = args->severity == GPR_LOG_SEVERITY_ERROR  ? "error"
                                 : args->severity == GPR_LOG_SEVERITY_INFO ? "info"
                                                                           : "debug";
  JsonLine line(level, "grpc");
  line.Str("message", args->message != nullptr ? args->message : "");
  line.Str("source", absl::StrCat(args->file != nullptr ? args->file : "", ":", args->line));
  WriteLine(line.str());
}

}  // namespace

std::string JsonQuote(std::string_view s) {
  std::string out = "\"";
  for (size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c == '\n') {
      out += "\\n";
    } else if (c < 0x20 || c == 0x7F) {
      out += absl::StrFormat("\\u%04x", c);
    } else if (c < 0x80) {
      out += static_cast<char>(c);
    } else if (const size_t n = Utf8Length(s, i); n > 0) {
      out.append(s.substr(i, n));
      i += n;
      continue;
    } else {
      out += "\\ufffd";  // a byte that is not UTF-8
    }
    ++i;
  }
  out += '"';
  return out;
}

JsonLine::JsonLine(std::string_view level, std::string_view event) {
  out_ = absl::StrCat("{\"time\":\"", NowRfc3339(), "\"");
  Str("level", level);
  Str("event", event);
}

JsonLine& JsonLine::Str(std::string_view key, std::string_view value) {
  absl::StrAppend(&out_, ",", JsonQuote(key), ":", JsonQuote(value));
  return *this;
}

JsonLine& JsonLine::Int(std::string_view key, int64_t value) {
  absl::StrAppend(&out_, ",", JsonQuote(key), ":", value);
  return *this;
}

JsonLine& JsonLine::Num(std::string_view key, double value) {
  absl::StrAppend(&out_, ",", JsonQuote(key), ":", std::isfinite(value) ? absl::StrFormat("%.6g", value) : "null");
  return *this;
}

std::string JsonLine::str() const { return out_ + "}"; }

std::string JobLogJson(const JobReport& report, const JobParams& params, std::string_view peer) {
  JsonLine line(JobLevel(report.status), "job");
  line.Str("message", JobLogLine(report, params))
      .Str("job_id", report.job_id)
      .Str("flow", JobFlowName(report, params))
      .Int("vertices", report.vertices)
      .Int("iterations", report.flow.iterations_run);
  // kAutoIterations is 0, as in JobSpec.iterations: one type on every line.
  line.Int("iterations_asked", params.flow.iterations == kAutoIterations ? 0 : params.flow.iterations)
      .Str("stop_reason", report.status == "OK" ? StopReasonName(report.flow.stop_reason) : "")
      .Str("status", report.status)
      .Str("error", report.error)
      .Str("peer", peer)
      .Num("queue_seconds", report.queue_seconds)
      .Num("decode_seconds", report.decode_seconds)
      .Num("smooth_seconds", report.smooth_seconds)
      .Num("encode_seconds", report.encode_seconds)
      .Num("total_seconds", report.total_seconds);
  return line.str();
}

void LogJob(LogFormat format, const JobReport& report, const JobParams& params, std::string_view peer) {
  WriteLine(format == LogFormat::kJson ? JobLogJson(report, params, peer) : JobLogLine(report, params, peer));
}

std::string RefusalLogLine(const RefusedCall& call) {
  using io::Sv;
  return absl::StrCat("meshsmoothd refused method=", Sv(call.method), " reason=", Sv(call.reason),
                      " status=", GrpcCodeName(call.status.error_code()), " peer=", Sv(call.peer),
                      call.job_id.empty() ? "" : absl::StrCat(" job=", Sv(call.job_id)),
                      " error=", JsonQuote(call.status.error_message()));
}

std::string RefusalLogJson(const RefusedCall& call) {
  JsonLine line("warning", "refused");
  line.Str("message", RefusalLogLine(call))
      .Str("method", call.method)
      .Str("reason", call.reason)
      .Str("status", GrpcCodeName(call.status.error_code()))
      .Str("error", call.status.error_message())
      .Str("peer", call.peer);
  if (!call.job_id.empty()) line.Str("job_id", call.job_id);
  return line.str();
}

void LogRefusal(LogFormat format, const RefusedCall& call) {
  WriteLine(format == LogFormat::kJson ? RefusalLogJson(call) : RefusalLogLine(call));
}

void LogEvent(LogFormat format, std::string_view level, std::string_view event, std::string_view message,
              const std::function<void(JsonLine&)>& fields) {
  if (format == LogFormat::kText) return WriteLine(absl::StrCat("meshsmoothd: ", std::string(message)));
  JsonLine line(level, event);
  line.Str("message", message);
  if (fields) fields(line);
  WriteLine(line.str());
}

void LogJobEvent(LogFormat format, std::string_view level, std::string_view event, std::string_view job_id,
                 std::string_view message, const std::function<void(JsonLine&)>& fields) {
  using io::Sv;
  const std::string text = absl::StrCat("meshsmoothd job=", Sv(job_id), " ", Sv(message));
  if (format == LogFormat::kText) return WriteLine(text);
  JsonLine line(level, event);
  line.Str("message", text).Str("job_id", job_id);
  if (fields) fields(line);
  WriteLine(line.str());
}

void RouteGrpcLog(LogFormat format) {
  if (format == LogFormat::kJson) gpr_set_log_function(GrpcLogToJson);
}

}  // namespace meshsmooth::server
