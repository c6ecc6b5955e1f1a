// The job store's schema, written once for both databases (job_database.h).
#include "server/job_database.h"
#include "absl/strings/str_replace.h"

namespace meshsmooth::server {

std::string JobStoreSchema(std::string_view bytes_type, std::string_view int64_type) {
  static constexpr char kSchema[] = R"sql(
CREATE TABLE IF NOT EXISTS uploads(
  request_id TEXT PRIMARY KEY, spec BYTES NOT NULL, total_bytes INT64 NOT NULL, sha256 BYTES NOT NULL,
  received INT64 NOT NULL DEFAULT 0, job_id TEXT);
CREATE TABLE IF NOT EXISTS upload_chunks(
  request_id TEXT NOT NULL, "offset" INT64 NOT NULL, data BYTES NOT NULL, PRIMARY KEY(request_id, "offset"));
CREATE TABLE IF NOT EXISTS jobs(
  job_id TEXT PRIMARY KEY, request_id TEXT NOT NULL UNIQUE, state INTEGER NOT NULL, spec BYTES NOT NULL,
  upload_bytes INT64 NOT NULL, upload_sha256 BYTES NOT NULL, progress BYTES, summary BYTES,
  error_code INTEGER NOT NULL DEFAULT 0, error_message TEXT NOT NULL DEFAULT '',
  create_us INT64 NOT NULL, start_us INT64 NOT NULL DEFAULT 0, end_us INT64 NOT NULL DEFAULT 0,
  attempts INTEGER NOT NULL DEFAULT 0, event_sequence INT64 NOT NULL DEFAULT 1,
  result_bytes INT64 NOT NULL DEFAULT 0, result_sha256 BYTES,
  lease_owner TEXT NOT NULL DEFAULT '', lease_until_us INT64 NOT NULL DEFAULT 0);
CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs(state, create_us, job_id);
CREATE INDEX IF NOT EXISTS jobs_by_time ON jobs(create_us, job_id);
CREATE TABLE IF NOT EXISTS result_chunks(
  job_id TEXT NOT NULL, "offset" INT64 NOT NULL, data BYTES NOT NULL, PRIMARY KEY(job_id, "offset"));
)sql";
  return absl::StrReplaceAll(kSchema, {{"BYTES", absl::string_view(bytes_type.data(), bytes_type.size())},
                                       {"INT64", absl::string_view(int64_type.data(), int64_type.size())}});
}

}  // namespace meshsmooth::server
