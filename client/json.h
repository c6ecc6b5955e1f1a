// The CLI's --json output.
#pragma once

#include <string>

#include "google/protobuf/message.h"

namespace meshsmooth::client {

// `message` as indented JSON with the .proto field names (job_id, not jobId), as proto3's
// JSON mapping writes it (64-bit integers as strings, fields at their default left out).
std::string ToJson(const google::protobuf::Message& message);

// The same on one line, without a newline at its end: a record of --json lines.
std::string ToJsonLine(const google::protobuf::Message& message);

}  // namespace meshsmooth::client
