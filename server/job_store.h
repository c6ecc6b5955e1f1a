// The job store: jobs that outlive a connection (smoothing.proto, Submit .. FetchResult) kept in
// one SQLite database under a directory, so that they survive the process (SIGKILL included).
//
// What it holds: uploads by the client's request id, their bytes in chunk rows as they arrive
// (the resumable upload), the jobs once an upload is committed (spec, state, progress, summary,
// error, times) and their results in chunk rows. Meshes go in rows of at most 1 MiB rather than
// in files beside the database so that a chunk, the count of bytes held and a state change
// commit together in one transaction: after a crash the store holds exactly what it
// acknowledged. WAL with synchronous=FULL: a committed transaction survives a SIGKILL and a
// power cut. auto_vacuum=INCREMENTAL gives the pages of deleted bytes back to the file system.
//
// One process owns a store at a time (an exclusive lock on DIR/lock); every method is
// thread-safe (one connection behind a mutex). Times are microseconds since the Unix epoch.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "meshsmooth/v1/smoothing.pb.h"

struct sqlite3;

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

// SHA-256 of `bytes` (32 bytes).
std::string Sha256(std::string_view bytes);

class JobStore {
 public:
  // Opens (creating when missing) DIR/jobs.sqlite3; jobs found RUNNING (the previous process
  // died under them) are QUEUED again. FailedPrecondition when the directory cannot be made or
  // another process holds the store; Internal for a database SQLite cannot open.
  static absl::StatusOr<std::unique_ptr<JobStore>> Open(const std::string& dir);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  // Jobs found RUNNING at Open() and queued again.
  int requeued_at_open() const { return requeued_at_open_; }
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

  // The oldest QUEUED job not in `skip`, or nullopt.
  std::optional<std::string> NextQueued(const std::vector<std::string>& skip);
  // QUEUED -> RUNNING (start time, one attempt more) and the job's input; nullopt when the job
  // is no longer QUEUED (cancelled or deleted meanwhile).
  std::optional<JobInput> StartRun(const std::string& job_id, int64_t now_us);
  // The newest progress of a RUNNING job (nothing once it left RUNNING).
  void SetProgress(const std::string& job_id, const v1::Progress& progress);
  // RUNNING -> SUCCEEDED with the result and its summary; false when the job was no longer
  // RUNNING (cancelled meanwhile), and nothing is kept.
  bool Succeed(const std::string& job_id, const std::string& result, const v1::Summary& summary, int64_t now_us);
  // RUNNING -> FAILED with the status' code and message; false when no longer RUNNING.
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

 private:
  JobStore() = default;
  absl::Status Exec(const char* sql);
  // Forgets an ended job's rows; mu_ held, inside a transaction.
  void DeleteLocked(const std::string& job_id, const std::string& request_id);
  absl::StatusOr<v1::Job> GetLocked(const std::string& job_id, bool with_details);
  void ReclaimLocked();

  std::mutex mu_;
  sqlite3* db_ = nullptr;
  int lock_fd_ = -1;
  int requeued_at_open_ = 0;
};

}  // namespace meshsmooth::server
