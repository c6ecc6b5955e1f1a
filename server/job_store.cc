#include "server/job_store.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "server/options.h"

namespace meshsmooth::server {
namespace {

constexpr char kSchema[] = R"sql(
CREATE TABLE IF NOT EXISTS uploads(
  request_id TEXT PRIMARY KEY, spec BLOB NOT NULL, total_bytes INTEGER NOT NULL, sha256 BLOB NOT NULL,
  received INTEGER NOT NULL DEFAULT 0, job_id TEXT);
CREATE TABLE IF NOT EXISTS upload_chunks(
  request_id TEXT NOT NULL, offset INTEGER NOT NULL, data BLOB NOT NULL, PRIMARY KEY(request_id, offset));
CREATE TABLE IF NOT EXISTS jobs(
  job_id TEXT PRIMARY KEY, request_id TEXT NOT NULL UNIQUE, state INTEGER NOT NULL, spec BLOB NOT NULL,
  upload_bytes INTEGER NOT NULL, upload_sha256 BLOB NOT NULL, progress BLOB, summary BLOB,
  error_code INTEGER NOT NULL DEFAULT 0, error_message TEXT NOT NULL DEFAULT '',
  create_us INTEGER NOT NULL, start_us INTEGER NOT NULL DEFAULT 0, end_us INTEGER NOT NULL DEFAULT 0,
  attempts INTEGER NOT NULL DEFAULT 0, event_sequence INTEGER NOT NULL DEFAULT 1,
  result_bytes INTEGER NOT NULL DEFAULT 0, result_sha256 BLOB);
CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs(state, create_us, job_id);
CREATE INDEX IF NOT EXISTS jobs_by_time ON jobs(create_us, job_id);
CREATE TABLE IF NOT EXISTS result_chunks(
  job_id TEXT NOT NULL, offset INTEGER NOT NULL, data BLOB NOT NULL, PRIMARY KEY(job_id, offset));
)sql";

// One prepared statement, finalized when it goes; Bind* take 1-based positions.
class Stmt {
 public:
  Stmt(sqlite3* db, const char* sql) { sqlite3_prepare_v2(db, sql, -1, &s_, nullptr); }
  ~Stmt() { sqlite3_finalize(s_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  Stmt& Text(int i, std::string_view v) {
    sqlite3_bind_text(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Stmt& Blob(int i, std::string_view v) {
    sqlite3_bind_blob64(s_, i, v.data(), v.size(), SQLITE_TRANSIENT);
    return *this;
  }
  Stmt& Int(int i, int64_t v) {
    sqlite3_bind_int64(s_, i, v);
    return *this;
  }
  // True while a row is there.
  bool Step() { return sqlite3_step(s_) == SQLITE_ROW; }
  // Runs a statement that returns no row; its SQLite code.
  int Run() { return sqlite3_step(s_); }
  int64_t ColInt(int i) { return sqlite3_column_int64(s_, i); }
  std::string ColBlob(int i) {
    const void* p = sqlite3_column_blob(s_, i);
    return p == nullptr ? std::string() : std::string(static_cast<const char*>(p), sqlite3_column_bytes(s_, i));
  }

 private:
  sqlite3_stmt* s_ = nullptr;
};

bool Ended(int state) {
  return state == v1::JOB_STATE_SUCCEEDED || state == v1::JOB_STATE_FAILED || state == v1::JOB_STATE_CANCELLED;
}

void SetTime(int64_t us, google::protobuf::Timestamp* t) {
  t->set_seconds(us / 1'000'000);
  t->set_nanos(static_cast<int32_t>(us % 1'000'000) * 1000);
}

constexpr char kJobColumns[] =
    "job_id, request_id, state, spec, upload_bytes, upload_sha256, progress, summary, error_code, error_message, "
    "create_us, start_us, end_us, attempts, event_sequence, result_bytes, result_sha256";

// A row of kJobColumns as a Job; the spec, progress and summary only `with_details`.
v1::Job JobOfRow(Stmt& q, bool with_details) {
  v1::Job j;
  j.set_job_id(q.ColBlob(0));
  j.set_request_id(q.ColBlob(1));
  j.set_state(static_cast<v1::JobState>(q.ColInt(2)));
  if (with_details) {
    j.mutable_spec()->ParseFromString(q.ColBlob(3));
    if (std::string p = q.ColBlob(6); !p.empty()) j.mutable_progress()->ParseFromString(p);
    if (std::string s = q.ColBlob(7); !s.empty()) j.mutable_summary()->ParseFromString(s);
  }
  j.set_upload_bytes(static_cast<uint64_t>(q.ColInt(4)));
  j.set_upload_sha256(q.ColBlob(5));
  if (j.state() == v1::JOB_STATE_FAILED) {
    j.mutable_error()->set_code(static_cast<int32_t>(q.ColInt(8)));
    j.mutable_error()->set_message(q.ColBlob(9));
  }
  SetTime(q.ColInt(10), j.mutable_create_time());
  if (q.ColInt(11) != 0) SetTime(q.ColInt(11), j.mutable_start_time());
  if (q.ColInt(12) != 0) SetTime(q.ColInt(12), j.mutable_end_time());
  j.set_attempts(static_cast<uint32_t>(q.ColInt(13)));
  j.set_event_sequence(static_cast<uint64_t>(q.ColInt(14)));
  if (j.state() == v1::JOB_STATE_SUCCEEDED) {
    j.set_result_bytes(static_cast<uint64_t>(q.ColInt(15)));
    j.set_result_sha256(q.ColBlob(16));
  }
  return j;
}

// The page token: the last job's create time and id.
std::string PageToken(const v1::Job& j) {
  return absl::StrCat(j.create_time().seconds() * 1'000'000 + j.create_time().nanos() / 1000, ":", j.job_id());
}

}  // namespace

std::string Sha256(std::string_view bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_Digest(bytes.data(), bytes.size(), digest, &n, EVP_sha256(), nullptr);
  return std::string(reinterpret_cast<const char*>(digest), n);
}

absl::StatusOr<std::unique_ptr<JobStore>> JobStore::Open(const std::string& dir) {
  if (mkdir(dir.c_str(), 0750) != 0 && errno != EEXIST) {
    return absl::FailedPreconditionError(absl::StrCat("cannot make the job store ", dir, ": ", std::strerror(errno)));
  }
  std::unique_ptr<JobStore> store(new JobStore());
  const std::string lock = dir + "/lock";
  store->lock_fd_ = open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0640);
  if (store->lock_fd_ < 0) {
    return absl::FailedPreconditionError(absl::StrCat("cannot open ", lock, ": ", std::strerror(errno)));
  }
  if (flock(store->lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("the job store ", dir, " is in use by another meshsmoothd (one process per store)"));
  }
  const std::string path = dir + "/jobs.sqlite3";
  if (sqlite3_open_v2(path.c_str(), &store->db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    return absl::InternalError(absl::StrCat("cannot open the job store's database ", path, ": ",
                                            store->db_ ? sqlite3_errmsg(store->db_) : "out of memory"));
  }
  // auto_vacuum takes effect only before the first table exists.
  for (const char* pragma : {"PRAGMA auto_vacuum=INCREMENTAL", "PRAGMA journal_mode=WAL", "PRAGMA synchronous=FULL",
                             "PRAGMA busy_timeout=5000"}) {
    if (absl::Status s = store->Exec(pragma); !s.ok()) return s;
  }
  if (absl::Status s = store->Exec(kSchema); !s.ok()) return s;
  Stmt requeue(store->db_, "UPDATE jobs SET state=?1, event_sequence=event_sequence+1 WHERE state=?2");
  requeue.Int(1, v1::JOB_STATE_QUEUED).Int(2, v1::JOB_STATE_RUNNING).Run();
  store->requeued_at_open_ = sqlite3_changes(store->db_);
  return store;
}

JobStore::~JobStore() {
  if (db_ != nullptr) sqlite3_close_v2(db_);
  if (lock_fd_ >= 0) close(lock_fd_);
}

absl::Status JobStore::Exec(const char* sql) {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    absl::Status s = absl::InternalError(absl::StrCat("job store: ", err ? err : "error", " in ", sql));
    sqlite3_free(err);
    return s;
  }
  return absl::OkStatus();
}

int64_t JobStore::stored_bytes() {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt q(db_,
         "SELECT (SELECT COALESCE(SUM(length(data)),0) FROM upload_chunks) + "
         "(SELECT COALESCE(SUM(length(data)),0) FROM result_chunks)");
  return q.Step() ? q.ColInt(0) : 0;
}

absl::StatusOr<UploadState> JobStore::StartUpload(const std::string& request_id, const std::string& spec,
                                                  uint64_t total_bytes, const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt q(db_, "SELECT spec, total_bytes, sha256, received, job_id FROM uploads WHERE request_id=?1");
  if (q.Text(1, request_id).Step()) {
    if (q.ColBlob(0) != spec || static_cast<uint64_t>(q.ColInt(1)) != total_bytes || q.ColBlob(2) != sha256) {
      return absl::AlreadyExistsError(absl::StrCat("request id '", request_id,
                                                   "' was sent before with another spec, length or checksum; "
                                                   "a new job needs a new request id"));
    }
    return UploadState{static_cast<uint64_t>(q.ColInt(3)), q.ColBlob(4)};
  }
  Stmt ins(db_, "INSERT INTO uploads(request_id, spec, total_bytes, sha256) VALUES(?1, ?2, ?3, ?4)");
  if (ins.Text(1, request_id).Blob(2, spec).Int(3, static_cast<int64_t>(total_bytes)).Blob(4, sha256).Run() !=
      SQLITE_DONE) {
    return absl::InternalError(absl::StrCat("job store: ", sqlite3_errmsg(db_)));
  }
  return UploadState{};
}

std::optional<UploadState> JobStore::QueryUpload(const std::string& request_id) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt q(db_, "SELECT received, job_id FROM uploads WHERE request_id=?1");
  if (!q.Text(1, request_id).Step()) return std::nullopt;
  return UploadState{static_cast<uint64_t>(q.ColInt(0)), q.ColBlob(1)};
}

absl::StatusOr<uint64_t> JobStore::AppendChunk(const std::string& request_id, uint64_t offset,
                                               const std::string& data) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt q(db_, "SELECT received, total_bytes, job_id FROM uploads WHERE request_id=?1");
  if (!q.Text(1, request_id).Step()) return absl::NotFoundError(absl::StrCat("no upload '", request_id, "'"));
  const uint64_t received = static_cast<uint64_t>(q.ColInt(0)), total = static_cast<uint64_t>(q.ColInt(1));
  if (!q.ColBlob(2).empty()) {
    return absl::FailedPreconditionError(
        absl::StrCat("the upload of request id '", request_id, "' is already committed: send no more chunks"));
  }
  if (offset != received) {
    return absl::FailedPreconditionError(absl::StrCat("a chunk at offset ", offset, ", but the server holds ", received,
                                                      " bytes of this upload: send from offset ", received,
                                                      " (QueryUpload says it too)"));
  }
  if (offset + data.size() > total) {
    return absl::InvalidArgumentError(absl::StrCat("a chunk of ", data.size(), " bytes at offset ", offset,
                                                   " ends past the upload's total_bytes ", total));
  }
  if (absl::Status s = Exec("BEGIN IMMEDIATE"); !s.ok()) return s;
  Stmt ins(db_, "INSERT INTO upload_chunks(request_id, offset, data) VALUES(?1, ?2, ?3)");
  Stmt up(db_, "UPDATE uploads SET received=?2 WHERE request_id=?1");
  const bool ok = ins.Text(1, request_id).Int(2, static_cast<int64_t>(offset)).Blob(3, data).Run() == SQLITE_DONE &&
                  up.Text(1, request_id).Int(2, static_cast<int64_t>(offset + data.size())).Run() == SQLITE_DONE;
  if (!ok) {
    absl::Status s = absl::InternalError(absl::StrCat("job store: ", sqlite3_errmsg(db_)));
    Exec("ROLLBACK").IgnoreError();
    return s;
  }
  if (absl::Status s = Exec("COMMIT"); !s.ok()) return s;
  return offset + data.size();
}

absl::StatusOr<std::string> JobStore::Commit(const std::string& request_id, const std::string& job_id, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt q(db_, "SELECT spec, total_bytes, sha256, received, job_id FROM uploads WHERE request_id=?1");
  if (!q.Text(1, request_id).Step()) return absl::NotFoundError(absl::StrCat("no upload '", request_id, "'"));
  if (std::string done = q.ColBlob(4); !done.empty()) return done;
  const uint64_t total = static_cast<uint64_t>(q.ColInt(1)), received = static_cast<uint64_t>(q.ColInt(3));
  const std::string spec = q.ColBlob(0), declared = q.ColBlob(2);
  if (received != total) {
    return absl::FailedPreconditionError(
        absl::StrCat("the upload holds ", received, " of its ", total, " bytes: send from offset ", received));
  }
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  Stmt chunks(db_, "SELECT data FROM upload_chunks WHERE request_id=?1 ORDER BY offset");
  chunks.Text(1, request_id);
  while (chunks.Step()) {
    const std::string data = chunks.ColBlob(0);
    EVP_DigestUpdate(ctx, data.data(), data.size());
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_DigestFinal_ex(ctx, digest, &n);
  EVP_MD_CTX_free(ctx);
  if (absl::Status s = Exec("BEGIN IMMEDIATE"); !s.ok()) return s;
  if (std::string(reinterpret_cast<const char*>(digest), n) != declared) {
    Stmt del(db_, "DELETE FROM uploads WHERE request_id=?1");
    Stmt del_chunks(db_, "DELETE FROM upload_chunks WHERE request_id=?1");
    del.Text(1, request_id).Run();
    del_chunks.Text(1, request_id).Run();
    if (absl::Status s = Exec("COMMIT"); !s.ok()) return s;
    ReclaimLocked();
    return absl::DataLossError(absl::StrCat("the upload's ", total,
                                            " bytes do not match the SHA-256 given in SubmitStart.sha256; they "
                                            "were discarded and no job was queued: upload again from offset 0"));
  }
  Stmt ins(db_,
           "INSERT INTO jobs(job_id, request_id, state, spec, upload_bytes, upload_sha256, create_us) "
           "VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  Stmt up(db_, "UPDATE uploads SET job_id=?2 WHERE request_id=?1");
  const bool ok = ins.Text(1, job_id)
                          .Text(2, request_id)
                          .Int(3, v1::JOB_STATE_QUEUED)
                          .Blob(4, spec)
                          .Int(5, static_cast<int64_t>(total))
                          .Blob(6, declared)
                          .Int(7, now_us)
                          .Run() == SQLITE_DONE &&
                  up.Text(1, request_id).Text(2, job_id).Run() == SQLITE_DONE;
  if (!ok) {
    absl::Status s = absl::InternalError(absl::StrCat("job store: ", sqlite3_errmsg(db_)));
    Exec("ROLLBACK").IgnoreError();
    return s;
  }
  if (absl::Status s = Exec("COMMIT"); !s.ok()) return s;
  return job_id;
}

absl::StatusOr<v1::Job> JobStore::GetLocked(const std::string& job_id, bool with_details) {
  Stmt q(db_, absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE job_id=?1").c_str());
  if (!q.Text(1, job_id).Step()) return absl::NotFoundError(absl::StrCat("no job '", job_id, "' in this job store"));
  return JobOfRow(q, with_details);
}

absl::StatusOr<v1::Job> JobStore::Get(const std::string& job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  return GetLocked(job_id, /*with_details=*/true);
}

std::vector<v1::Job> JobStore::List(const std::vector<v1::JobState>& states, const std::string& after, int limit,
                                    std::string* next) {
  std::lock_guard<std::mutex> lock(mu_);
  int64_t after_us = -1;
  std::string after_id;
  if (const std::vector<std::string> parts = absl::StrSplit(after, absl::MaxSplits(':', 1)); parts.size() == 2) {
    after_us = std::strtoll(parts[0].c_str(), nullptr, 10);
    after_id = parts[1];
  }
  std::string state_list;
  for (v1::JobState s : states) absl::StrAppend(&state_list, state_list.empty() ? "" : ",", static_cast<int>(s));
  const std::string sql = absl::StrCat(
      "SELECT ", kJobColumns, " FROM jobs WHERE (create_us > ?1 OR (create_us = ?1 AND job_id > ?2))",
      states.empty() ? "" : absl::StrCat(" AND state IN (", state_list, ")"), " ORDER BY create_us, job_id LIMIT ?3");
  Stmt q(db_, sql.c_str());
  q.Int(1, after_us).Text(2, after_id).Int(3, limit + 1);
  std::vector<v1::Job> jobs;
  while (q.Step()) jobs.push_back(JobOfRow(q, /*with_details=*/false));
  next->clear();
  if (static_cast<int>(jobs.size()) > limit) {
    jobs.resize(limit);
    *next = PageToken(jobs.back());
  }
  return jobs;
}

std::optional<std::string> JobStore::NextQueued(const std::vector<std::string>& skip) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt q(db_, "SELECT job_id FROM jobs WHERE state=?1 ORDER BY create_us, job_id");
  q.Int(1, v1::JOB_STATE_QUEUED);
  while (q.Step()) {
    std::string id = q.ColBlob(0);
    if (std::find(skip.begin(), skip.end(), id) == skip.end()) return id;
  }
  return std::nullopt;
}

std::optional<JobInput> JobStore::StartRun(const std::string& job_id, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt up(db_,
          "UPDATE jobs SET state=?2, start_us=?3, attempts=attempts+1, event_sequence=event_sequence+1, "
          "progress=NULL WHERE job_id=?1 AND state=?4");
  up.Text(1, job_id).Int(2, v1::JOB_STATE_RUNNING).Int(3, now_us).Int(4, v1::JOB_STATE_QUEUED).Run();
  if (sqlite3_changes(db_) != 1) return std::nullopt;
  Stmt q(db_, "SELECT spec, request_id FROM jobs WHERE job_id=?1");
  if (!q.Text(1, job_id).Step()) return std::nullopt;
  JobInput input;
  input.spec.ParseFromString(q.ColBlob(0));
  Stmt chunks(db_, "SELECT data FROM upload_chunks WHERE request_id=?1 ORDER BY offset");
  chunks.Text(1, q.ColBlob(1));
  while (chunks.Step()) input.upload += chunks.ColBlob(0);
  return input;
}

void JobStore::SetProgress(const std::string& job_id, const v1::Progress& progress) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt up(db_, "UPDATE jobs SET progress=?2, event_sequence=event_sequence+1 WHERE job_id=?1 AND state=?3");
  up.Text(1, job_id).Blob(2, progress.SerializeAsString()).Int(3, v1::JOB_STATE_RUNNING).Run();
}

bool JobStore::Succeed(const std::string& job_id, const std::string& result, const v1::Summary& summary,
                       int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  if (!Exec("BEGIN IMMEDIATE").ok()) return false;
  Stmt up(db_,
          "UPDATE jobs SET state=?2, end_us=?3, summary=?4, result_bytes=?5, result_sha256=?6, "
          "event_sequence=event_sequence+1 WHERE job_id=?1 AND state=?7");
  up.Text(1, job_id)
      .Int(2, v1::JOB_STATE_SUCCEEDED)
      .Int(3, now_us)
      .Blob(4, summary.SerializeAsString())
      .Int(5, static_cast<int64_t>(result.size()))
      .Blob(6, Sha256(result))
      .Int(7, v1::JOB_STATE_RUNNING)
      .Run();
  if (sqlite3_changes(db_) != 1) {
    Exec("ROLLBACK").IgnoreError();
    return false;
  }
  Stmt del(db_, "DELETE FROM result_chunks WHERE job_id=?1");  // an earlier attempt's, if any
  del.Text(1, job_id).Run();
  for (size_t offset = 0; offset < result.size(); offset += kResultChunkBytes) {
    Stmt ins(db_, "INSERT INTO result_chunks(job_id, offset, data) VALUES(?1, ?2, ?3)");
    const std::string_view piece = std::string_view(result).substr(offset, kResultChunkBytes);
    if (ins.Text(1, job_id).Int(2, static_cast<int64_t>(offset)).Blob(3, piece).Run() != SQLITE_DONE) {
      Exec("ROLLBACK").IgnoreError();
      return false;
    }
  }
  return Exec("COMMIT").ok();
}

bool JobStore::Fail(const std::string& job_id, const absl::Status& status, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt up(db_,
          "UPDATE jobs SET state=?2, end_us=?3, error_code=?4, error_message=?5, event_sequence=event_sequence+1 "
          "WHERE job_id=?1 AND state=?6");
  up.Text(1, job_id)
      .Int(2, v1::JOB_STATE_FAILED)
      .Int(3, now_us)
      .Int(4, static_cast<int>(status.code()))
      .Text(5, std::string(status.message()))
      .Int(6, v1::JOB_STATE_RUNNING)
      .Run();
  return sqlite3_changes(db_) == 1;
}

absl::StatusOr<v1::Job> JobStore::Cancel(const std::string& job_id, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt up(db_,
          "UPDATE jobs SET state=?2, end_us=?3, event_sequence=event_sequence+1 WHERE job_id=?1 AND state IN (?4, ?5)");
  up.Text(1, job_id)
      .Int(2, v1::JOB_STATE_CANCELLED)
      .Int(3, now_us)
      .Int(4, v1::JOB_STATE_QUEUED)
      .Int(5, v1::JOB_STATE_RUNNING)
      .Run();
  return GetLocked(job_id, /*with_details=*/true);
}

void JobStore::DeleteLocked(const std::string& job_id, const std::string& request_id) {
  Stmt a(db_, "DELETE FROM jobs WHERE job_id=?1");
  Stmt b(db_, "DELETE FROM result_chunks WHERE job_id=?1");
  Stmt c(db_, "DELETE FROM uploads WHERE request_id=?1");
  Stmt d(db_, "DELETE FROM upload_chunks WHERE request_id=?1");
  a.Text(1, job_id).Run();
  b.Text(1, job_id).Run();
  c.Text(1, request_id).Run();
  d.Text(1, request_id).Run();
}

void JobStore::ReclaimLocked() {
  // The freed pages back to the file system: the WAL's into the database, then its free list.
  Exec("PRAGMA wal_checkpoint(TRUNCATE)").IgnoreError();
  Exec("PRAGMA incremental_vacuum").IgnoreError();
  Exec("PRAGMA wal_checkpoint(TRUNCATE)").IgnoreError();
}

absl::Status JobStore::Delete(const std::string& job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<v1::Job> job = GetLocked(job_id, /*with_details=*/false);
  if (!job.ok()) return job.status();
  if (!Ended(job->state())) {
    return absl::FailedPreconditionError(absl::StrCat("job '", job_id, "' is ", v1::JobState_Name(job->state()),
                                                      ": DeleteJob does not cancel; cancel it first (CancelJob)"));
  }
  if (absl::Status s = Exec("BEGIN IMMEDIATE"); !s.ok()) return s;
  DeleteLocked(job_id, job->request_id());
  if (absl::Status s = Exec("COMMIT"); !s.ok()) return s;
  ReclaimLocked();
  return absl::OkStatus();
}

absl::StatusOr<JobStore::ResultPiece> JobStore::ReadResult(const std::string& job_id, uint64_t offset,
                                                           uint64_t max_bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<v1::Job> job = GetLocked(job_id, /*with_details=*/false);
  if (!job.ok()) return job.status();
  if (job->state() != v1::JOB_STATE_SUCCEEDED) {
    return absl::FailedPreconditionError(
        absl::StrCat("job '", job_id, "' is ", v1::JobState_Name(job->state()), ": only a SUCCEEDED job has a result"));
  }
  ResultPiece piece{{}, job->result_bytes(), job->result_sha256()};
  if (offset > piece.total_bytes) {
    return absl::OutOfRangeError(
        absl::StrCat("offset ", offset, " is past the end of the result (", piece.total_bytes, " bytes)"));
  }
  Stmt q(db_, "SELECT offset, data FROM result_chunks WHERE job_id=?1 AND offset + length(data) > ?2 ORDER BY offset");
  q.Text(1, job_id).Int(2, static_cast<int64_t>(offset));
  while (piece.data.size() < max_bytes && q.Step()) {
    const uint64_t start = static_cast<uint64_t>(q.ColInt(0));
    const std::string data = q.ColBlob(1);
    const uint64_t from = offset + piece.data.size() - start;
    piece.data.append(data, from, max_bytes - piece.data.size());
  }
  return piece;
}

int JobStore::ExpireEndedBefore(int64_t cutoff_us) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt q(db_, "SELECT job_id, request_id FROM jobs WHERE end_us != 0 AND end_us < ?1");
  q.Int(1, cutoff_us);
  std::vector<std::pair<std::string, std::string>> expired;
  while (q.Step()) expired.emplace_back(q.ColBlob(0), q.ColBlob(1));
  if (expired.empty() || !Exec("BEGIN IMMEDIATE").ok()) return 0;
  for (const auto& [job, request] : expired) DeleteLocked(job, request);
  Exec("COMMIT").IgnoreError();
  ReclaimLocked();
  return static_cast<int>(expired.size());
}

bool JobStore::MakeRoom(int64_t bytes, int64_t budget) {
  for (;;) {
    std::string oldest_id, oldest_request;
    {
      std::lock_guard<std::mutex> lock(mu_);
      Stmt held(db_,
                "SELECT (SELECT COALESCE(SUM(length(data)),0) FROM upload_chunks) + "
                "(SELECT COALESCE(SUM(length(data)),0) FROM result_chunks)");
      if (held.Step() && held.ColInt(0) + bytes <= budget) return true;
      Stmt q(db_, "SELECT job_id, request_id FROM jobs WHERE end_us != 0 ORDER BY end_us LIMIT 1");
      if (!q.Step()) return false;
      oldest_id = q.ColBlob(0);
      oldest_request = q.ColBlob(1);
      if (!Exec("BEGIN IMMEDIATE").ok()) return false;
      DeleteLocked(oldest_id, oldest_request);
      Exec("COMMIT").IgnoreError();
      ReclaimLocked();
    }
  }
}

}  // namespace meshsmooth::server
