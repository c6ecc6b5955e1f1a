// The job store: jobs that outlive a connection (smoothing.proto, Submit .. FetchResult) kept in
// a database (server/job_database.h), so that they survive the process (SIGKILL included): a
// SQLite file under a directory for one meshsmoothd, or a PostgreSQL database that any number of
// replicas share.
//
// What it holds: uploads by the client's request id, their bytes in chunk rows as they arrive
// (the resumable upload), the jobs once an upload is committed (spec, state, progress, summary,
// error, times, lease) and their results in chunk rows. Meshes go in rows of at most 1 MiB rather
// than in files beside the database so that a chunk, the count of bytes held and a state change
// commit together in one transaction: after a crash the store holds exactly what it
// acknowledged.
//
// A running job holds a lease: this store's owner id and a time (--job-lease from the claim or
// the last renewal). The runner renews it while the job runs; a job whose lease ran out (its
// replica died) is claimed again by the next replica that looks, as a QUEUED one is. A run's
// progress and end are kept only while its lease is still this store's, so a replica that lost
// its job never overwrites the run that took it over.
//
// Every method is thread-safe (one connection behind a mutex). Times are microseconds since the
// Unix epoch.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "server/job_database.h"

namespace meshsmooth::server {

// An upload as the store holds it.
struct UploadState {
  uint64_t bytes_received = 0;
  std::string job_id;  // non-empty once committed
};

// A job taken to run: its spec and its upload's bytes.
struct JobInput {
  v1::JobSpec spec;
  std::string upload;
};

// A job taken to run by Claim.
struct ClaimedJob {
  std::string job_id;
  JobInput input;
  bool takeover = false;  // it was RUNNING under a lease that had run out (its replica died)
};

// The jobs of the whole store by state, for the metrics.
struct JobCounts {
  std::array<int64_t, 6> by_state{};  // by v1::JobState
  int64_t oldest_queued_us = 0;       // the oldest QUEUED job's create time; 0: none queued
};

struct JobStoreOptions {
  // How long a claim or renewal keeps a running job this store's (--job-lease).
  double lease_seconds = 30.0;
};

// SHA-256 of `bytes` (32 bytes).
std::string Sha256(std::string_view bytes);

// A new job id: 32 lowercase hex digits of 128 random bits (OpenSSL's RAND_bytes).
std::string NewStoredJobId();

class JobStore {
 public:
  // Opens `where`: a postgresql:// URI (OpenPostgresJobDatabase), else a directory
  // (OpenSqliteJobDatabase, whose errors it returns). In a directory, jobs found RUNNING (the
  // previous process died under them) are QUEUED again; in PostgreSQL their leases say when.
  static absl::StatusOr<std::unique_ptr<JobStore>> Open(const std::string& where, const JobStoreOptions& options = {});
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  // Jobs found RUNNING at Open() and queued again.
  int requeued_at_open() const { return requeued_at_open_; }
  // Other processes share the store (PostgreSQL): their changes show only in its rows.
  bool shared() const { return db_->shared(); }
  // This store's lease owner: host, process id and a random tag.
  const std::string& owner() const { return owner_; }
  // Bytes of uploads and results held (the disk budget counts these).
  int64_t stored_bytes();

  // The upload for `request_id`: a new one is recorded with its spec (serialized), length and
  // checksum; an existing one must have the same three, else AlreadyExists.
  absl::StatusOr<UploadState> StartUpload(const std::string& request_id, const std::string& spec, uint64_t total_bytes,
                                          const std::string& sha256);
  // The upload as held; nullopt for a request id never seen.
  std::optional<UploadState> QueryUpload(const std::string& request_id);
  // Keeps `data` at `offset`: FailedPrecondition naming the expected offset unless `offset` is
  // the bytes held; InvalidArgument past the declared length. Returns the bytes held after it.
  absl::StatusOr<uint64_t> AppendChunk(const std::string& request_id, uint64_t offset, const std::string& data);
  // Commits a complete upload as the job `job_id` (QUEUED, created `now_us`): DataLoss (the
  // bytes discarded, the upload starting again from 0) when their SHA-256 is not the declared
  // one; FailedPrecondition while bytes are missing. Returns the job id (the earlier one when
  // already committed).
  absl::StatusOr<std::string> Commit(const std::string& request_id, const std::string& job_id, int64_t now_us);

  // The job, with its spec and everything else; NotFound naming the id.
  absl::StatusOr<v1::Job> Get(const std::string& job_id);
  // Jobs in `states` (empty: all), in the order of (create time, id) after `after` (a page
  // token: empty for the first page), at most `limit`; the next page's token in `next`.
  std::vector<v1::Job> List(const std::vector<v1::JobState>& states, const std::string& after, int limit,
                            std::string* next);

  // Takes the oldest job that is QUEUED, or RUNNING under a lease that ended before `now_us`,
  // and not in `skip`: RUNNING under this store's lease (start time, one attempt more) with its
  // input; nullopt when there is none. Replicas claiming at once take different jobs.
  std::optional<ClaimedJob> Claim(const std::vector<std::string>& skip, int64_t now_us);
  // Extends the lease of a job this store runs to `now_us` + the lease; false when the job is no
  // longer RUNNING under this store's lease (cancelled, deleted, or taken over).
  bool RenewLease(const std::string& job_id, int64_t now_us);
  // A job this store claimed back to QUEUED, its lease given up (the server stops, or its pool
  // had no room); `undo_attempt` when it never started to run.
  void Release(const std::string& job_id, bool undo_attempt);
  // The newest progress of a job running under this store's lease (nothing once it left it).
  void SetProgress(const std::string& job_id, const v1::Progress& progress);
  // RUNNING -> SUCCEEDED with the result and its summary; false when the job was no longer
  // RUNNING under this store's lease (cancelled or taken over meanwhile), and nothing is kept.
  bool Succeed(const std::string& job_id, const std::string& result, const v1::Summary& summary, int64_t now_us);
  // RUNNING -> FAILED with the status' code and message; false as for Succeed.
  bool Fail(const std::string& job_id, const absl::Status& status, int64_t now_us);
  // QUEUED or RUNNING -> CANCELLED; an ended job keeps its state. Returns the job afterwards;
  // NotFound naming the id.
  absl::StatusOr<v1::Job> Cancel(const std::string& job_id, int64_t now_us);
  // Forgets an ended job, its upload and its result; NotFound, or FailedPrecondition for a job
  // that has not ended.
  absl::Status Delete(const std::string& job_id);

  // Up to `max_bytes` of a SUCCEEDED job's result from `offset`, with its length and SHA-256:
  // NotFound, FailedPrecondition (not SUCCEEDED), OutOfRange (offset past the end).
  struct ResultPiece {
    std::string data;
    uint64_t total_bytes = 0;
    std::string sha256;
  };
  absl::StatusOr<ResultPiece> ReadResult(const std::string& job_id, uint64_t offset, uint64_t max_bytes);

  // Forgets the jobs that ended before `cutoff_us`; returns how many.
  int ExpireEndedBefore(int64_t cutoff_us);
  // Makes room for `bytes` more under `budget`, forgetting ended jobs oldest end first; false
  // when even that does not make room.
  bool MakeRoom(int64_t bytes, int64_t budget);

  // The jobs by state and the oldest queued one (the whole store, every replica's jobs).
  JobCounts Counts();

 private:
  JobStore(std::unique_ptr<JobDatabase> db, const JobStoreOptions& options);
  // A statement; mu_ held.
  absl::StatusOr<SqlResult> Q(std::string_view sql, const std::vector<SqlArg>& args = {});
  // Forgets ended jobs' rows, each in its own transaction, then gives the pages back; mu_ held.
  void ForgetLocked(const std::vector<std::pair<std::string, std::string>>& jobs_and_requests);
  absl::StatusOr<v1::Job> GetLocked(const std::string& job_id, bool with_details);
  int64_t StoredBytesLocked();

  std::mutex mu_;
  std::unique_ptr<JobDatabase> db_;
  const JobStoreOptions options_;
  const std::string owner_;
  int requeued_at_open_ = 0;
};

}  // namespace meshsmooth::server
