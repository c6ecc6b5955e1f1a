// meshsmoothd's log on stderr: one entry per job, per refused call, per event of a kept job and
// per lifecycle event (listening, shutting down, stopped, a shutdown cut short), as text for a
// terminal or, with --log-format json, as one JSON object a line for a log pipeline.
//
// Every JSON entry has "time" (RFC 3339, UTC, milliseconds), "level" ("info", "warning" or
// "error"), "event" and "message". A job's entry ("event":"job"; level "info" when it succeeded,
// "warning" or "error" when it failed) adds job_id, flow, vertices, iterations,
// iterations_asked (always a number: 0 for automatic stopping, as JobSpec.iterations),
// stop_reason, status (the gRPC code's name), error (the status message of a failed job; empty
// when it succeeded), peer (gRPC's form, "ipv4:127.0.0.1:40312"), queue_seconds,
// decode_seconds, smooth_seconds, encode_seconds and total_seconds. A call refused before a job
// ran ("event":"refused", level "warning": a wrong token, a bad spec or message order, a size
// limit, a full queue or memory budget, an idle upload, a shutdown) adds method ("Smooth" or
// "ListFlows"), reason (the metrics' refusal label, metrics.h), status, error, peer and, once
// the call's spec was read, job_id. An event of a kept job ("event" "job_submitted",
// "job_cancelled", "job_deleted" or "callback") adds job_id, a submit's request_id and
// upload_bytes, and a callback's attempt, http_status (0 when no answer came), outcome
// ("delivered", "retry", "gave_up", "dropped") and error. gRPC's own log lines become entries
// with "event":"grpc".
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "grpcpp/support/status.h"
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

// A call refused before its job ran, for the log.
struct RefusedCall {
  std::string_view method;  // "Smooth", "ListFlows"
  std::string_view reason;  // RefusalName()
  const grpc::Status& status;
  std::string_view peer;
  std::string_view job_id;  // empty when no spec was read
};

// Its text line, without a newline: "meshsmoothd refused method=M reason=R status=CODE peer=P
// [job=ID] error=\"MESSAGE\"" (the message quoted as a JSON string).
std::string RefusalLogLine(const RefusedCall& call);
// Its JSON entry, without a newline.
std::string RefusalLogJson(const RefusedCall& call);
// Writes its entry in `format` on stderr, in one write.
void LogRefusal(LogFormat format, const RefusedCall& call);

// Writes a lifecycle event on stderr: "meshsmoothd: <message>" as text; as JSON, with the fields
// `fields` adds after "message". `level`: "info", "warning" or "error".
void LogEvent(LogFormat format, std::string_view level, std::string_view event, std::string_view message,
              const std::function<void(JsonLine&)>& fields = nullptr);

// Writes an event of a kept job (its commit, cancel or deletion, a callback's delivery) on
// stderr: "meshsmoothd job=ID <message>" as text (never with " status=", which the run's line
// has); as JSON, "job_id" and the fields `fields` adds after "message".
void LogJobEvent(LogFormat format, std::string_view level, std::string_view event, std::string_view job_id,
                 std::string_view message, const std::function<void(JsonLine&)>& fields = nullptr);

// With kJson, gRPC's own log lines go to stderr as JSON entries ("event":"grpc") too.
void RouteGrpcLog(LogFormat format);

}  // namespace meshsmooth::server
