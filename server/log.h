// meshsmoothd's log on stderr: one entry per job and per lifecycle event (listening, shutting
// down, stopped, a shutdown cut short), as text for a terminal or, with --log-format json, as one
// JSON object a line for a log pipeline.
//
// Every JSON entry has "time" (RFC 3339, UTC, milliseconds), "level" ("info", "warning" or
// "error"), "event" and "message". A job's entry ("event":"job") adds job_id, flow, vertices,
// iterations, iterations_asked (a number, or "auto"), stop_reason, status (the gRPC code's name),
// peer (gRPC's form, "ipv4:127.0.0.1:40312"), queue_seconds, decode_seconds, smooth_seconds,
// encode_seconds and total_seconds. gRPC's own log lines become entries with "event":"grpc".
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "server/convert.h"
#include "server/options.h"

namespace meshsmooth::server {

// One JSON object, built field by field; str() closes it. Starts with time, level and event.
class JsonLine {
 public:
  JsonLine(std::string_view level, std::string_view event);
  JsonLine& Str(std::string_view key, std::string_view value);
  JsonLine& Int(std::string_view key, int64_t value);
  JsonLine& Num(std::string_view key, double value);  // null when not finite
  std::string str() const;                            // without a newline

 private:
  std::string out_;
};

// `s` as a JSON string, quotes included (control characters and non-UTF-8 bytes escaped).
std::string JsonQuote(std::string_view s);

// The job's JSON entry, without a newline.
std::string JobLogJson(const JobReport& report, const JobParams& params, std::string_view peer);

// Writes a job's entry in `format` on stderr, in one write.
void LogJob(LogFormat format, const JobReport& report, const JobParams& params, std::string_view peer);

// Writes a lifecycle event on stderr: "meshsmoothd: <message>" as text; as JSON, with the fields
// `fields` adds after "message". `level`: "info", "warning" or "error".
void LogEvent(LogFormat format, std::string_view level, std::string_view event, std::string_view message,
              const std::function<void(JsonLine&)>& fields = nullptr);

// With kJson, gRPC's own log lines go to stderr as JSON entries ("event":"grpc") too.
void RouteGrpcLog(LogFormat format);

}  // namespace meshsmooth::server
