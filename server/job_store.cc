#include "server/job_store.h"

#include <openssl/evp.h>
#include <openssl/rand.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <utility>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "server/options.h"

namespace meshsmooth::server {
namespace {

using Args = std::vector<SqlArg>;
using A = SqlArg;

bool Ended(int64_t state) {
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
v1::Job JobOfRow(const SqlRow& q, bool with_details) {
  v1::Job j;
  j.set_job_id(q.Bytes(0));
  j.set_request_id(q.Bytes(1));
  j.set_state(static_cast<v1::JobState>(q.Int(2)));
  if (with_details) {
    j.mutable_spec()->ParseFromString(q.Bytes(3));
    if (std::string p = q.Bytes(6); !p.empty()) j.mutable_progress()->ParseFromString(p);
    if (std::string s = q.Bytes(7); !s.empty()) j.mutable_summary()->ParseFromString(s);
  }
  j.set_upload_bytes(static_cast<uint64_t>(q.Int(4)));
  j.set_upload_sha256(q.Bytes(5));
  if (j.state() == v1::JOB_STATE_FAILED) {
    j.mutable_error()->set_code(static_cast<int32_t>(q.Int(8)));
    j.mutable_error()->set_message(q.Bytes(9));
  }
  SetTime(q.Int(10), j.mutable_create_time());
  if (q.Int(11) != 0) SetTime(q.Int(11), j.mutable_start_time());
  if (q.Int(12) != 0) SetTime(q.Int(12), j.mutable_end_time());
  j.set_attempts(static_cast<uint32_t>(q.Int(13)));
  j.set_event_sequence(static_cast<uint64_t>(q.Int(14)));
  if (j.state() == v1::JOB_STATE_SUCCEEDED) {
    j.set_result_bytes(static_cast<uint64_t>(q.Int(15)));
    j.set_result_sha256(q.Bytes(16));
  }
  return j;
}

// The page token: the last job's create time and id.
std::string PageToken(const v1::Job& j) {
  return absl::StrCat(j.create_time().seconds() * 1'000'000 + j.create_time().nanos() / 1000, ":", j.job_id());
}

// A transaction rolled back unless committed.
class Transaction {
 public:
  explicit Transaction(JobDatabase& db) : db_(db), begun_(db.Begin()) {}
  ~Transaction() {
    if (begun_.ok() && !done_) db_.Rollback();
  }
  const absl::Status& begun() const { return begun_; }
  absl::Status Commit() {
    done_ = true;
    return db_.Commit();
  }

 private:
  JobDatabase& db_;
  const absl::Status begun_;
  bool done_ = false;
};

// host-pid-random: unique among the replicas, and says which one holds a lease.
std::string MakeOwner() {
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  return absl::StrCat(host, "-", getpid(), "-", NewStoredJobId().substr(0, 8));
}

constexpr char kStoredBytes[] =
    "SELECT (SELECT COALESCE(SUM(length(data)),0) FROM upload_chunks) + "
    "(SELECT COALESCE(SUM(length(data)),0) FROM result_chunks)";

}  // namespace

std::string Sha256(std::string_view bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_Digest(bytes.data(), bytes.size(), digest, &n, EVP_sha256(), nullptr);
  return std::string(reinterpret_cast<const char*>(digest), n);
}

std::string NewStoredJobId() {
  unsigned char bytes[16];
  if (RAND_bytes(bytes, sizeof bytes) != 1) std::abort();  // no randomness: no unguessable ids
  return absl::BytesToHexString(absl::string_view(reinterpret_cast<const char*>(bytes), sizeof bytes));
}

JobStore::JobStore(std::unique_ptr<JobDatabase> db, const JobStoreOptions& options)
    : db_(std::move(db)), options_(options), owner_(MakeOwner()) {}

absl::StatusOr<std::unique_ptr<JobStore>> JobStore::Open(const std::string& where, const JobStoreOptions& options) {
  absl::StatusOr<std::unique_ptr<JobDatabase>> db =
      IsPostgresUri(where) ? OpenPostgresJobDatabase(where) : OpenSqliteJobDatabase(where);
  if (!db.ok()) return db.status();
  std::unique_ptr<JobStore> store(new JobStore(*std::move(db), options));
  if (!store->db_->shared()) {  // this process owns the store: what was RUNNING died with the last one
    absl::StatusOr<SqlResult> requeued = store->Q(
        "UPDATE jobs SET state=?1, lease_owner='', lease_until_us=0, event_sequence=event_sequence+1 WHERE state=?2",
        {A::Int(v1::JOB_STATE_QUEUED), A::Int(v1::JOB_STATE_RUNNING)});
    if (!requeued.ok()) return requeued.status();
    store->requeued_at_open_ = static_cast<int>(requeued->changed);
  }
  return store;
}

JobStore::~JobStore() = default;

absl::StatusOr<SqlResult> JobStore::Q(std::string_view sql, const std::vector<SqlArg>& args) {
  return db_->Run(sql, args);
}

int64_t JobStore::StoredBytesLocked() {
  absl::StatusOr<SqlResult> r = Q(kStoredBytes);
  return r.ok() && !r->rows.empty() ? r->rows[0].Int(0) : 0;
}

int64_t JobStore::stored_bytes() {
  std::lock_guard<std::mutex> lock(mu_);
  return StoredBytesLocked();
}

absl::StatusOr<UploadState> JobStore::StartUpload(const std::string& request_id, const std::string& spec,
                                                  uint64_t total_bytes, const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  // Another replica may record the same request id at the same time: the first row stays.
  absl::StatusOr<SqlResult> ins =
      Q("INSERT INTO uploads(request_id, spec, total_bytes, sha256) VALUES(?1, ?2, ?3, ?4) ON CONFLICT DO NOTHING",
        {A::Text(request_id), A::Bytes(spec), A::Int(static_cast<int64_t>(total_bytes)), A::Bytes(sha256)});
  if (!ins.ok()) return ins.status();
  if (ins->changed == 1) return UploadState{};
  absl::StatusOr<SqlResult> q =
      Q("SELECT spec, total_bytes, sha256, received, job_id FROM uploads WHERE request_id=?1", {A::Text(request_id)});
  if (!q.ok()) return q.status();
  if (q->rows.empty()) return absl::AbortedError(absl::StrCat("the upload '", request_id, "' went meanwhile: retry"));
  const SqlRow& r = q->rows[0];
  if (r.Bytes(0) != spec || static_cast<uint64_t>(r.Int(1)) != total_bytes || r.Bytes(2) != sha256) {
    return absl::AlreadyExistsError(absl::StrCat("request id '", request_id,
                                                 "' was sent before with another spec, length or checksum; "
                                                 "a new job needs a new request id"));
  }
  return UploadState{static_cast<uint64_t>(r.Int(3)), r.Bytes(4)};
}

std::optional<UploadState> JobStore::QueryUpload(const std::string& request_id) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<SqlResult> q = Q("SELECT received, job_id FROM uploads WHERE request_id=?1", {A::Text(request_id)});
  if (!q.ok() || q->rows.empty()) return std::nullopt;
  return UploadState{static_cast<uint64_t>(q->rows[0].Int(0)), q->rows[0].Bytes(1)};
}

absl::StatusOr<uint64_t> JobStore::AppendChunk(const std::string& request_id, uint64_t offset,
                                               const std::string& data) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<SqlResult> q =
      Q("SELECT received, total_bytes, job_id FROM uploads WHERE request_id=?1", {A::Text(request_id)});
  if (!q.ok()) return q.status();
  if (q->rows.empty()) return absl::NotFoundError(absl::StrCat("no upload '", request_id, "'"));
  const SqlRow& r = q->rows[0];
  const uint64_t received = static_cast<uint64_t>(r.Int(0)), total = static_cast<uint64_t>(r.Int(1));
  if (!r.Bytes(2).empty()) {
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
  Transaction tx(*db_);
  if (!tx.begun().ok()) return tx.begun();
  const int64_t end = static_cast<int64_t>(offset + data.size());
  absl::StatusOr<SqlResult> ins = Q("INSERT INTO upload_chunks(request_id, \"offset\", data) VALUES(?1, ?2, ?3)",
                                    {A::Text(request_id), A::Int(static_cast<int64_t>(offset)), A::Bytes(data)});
  if (!ins.ok()) return ins.status();
  // Only from the count read above: a replica that appended the same chunk meanwhile wins.
  absl::StatusOr<SqlResult> up = Q("UPDATE uploads SET received=?2 WHERE request_id=?1 AND received=?3",
                                   {A::Text(request_id), A::Int(end), A::Int(static_cast<int64_t>(offset))});
  if (!up.ok()) return up.status();
  if (up->changed != 1) return absl::AbortedError("another call appended to this upload meanwhile: QueryUpload");
  if (absl::Status s = tx.Commit(); !s.ok()) return s;
  return static_cast<uint64_t>(end);
}

absl::StatusOr<std::string> JobStore::Commit(const std::string& request_id, const std::string& job_id, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<SqlResult> q =
      Q("SELECT spec, total_bytes, sha256, received, job_id FROM uploads WHERE request_id=?1", {A::Text(request_id)});
  if (!q.ok()) return q.status();
  if (q->rows.empty()) return absl::NotFoundError(absl::StrCat("no upload '", request_id, "'"));
  const SqlRow& r = q->rows[0];
  if (std::string done = r.Bytes(4); !done.empty()) return done;
  const uint64_t total = static_cast<uint64_t>(r.Int(1)), received = static_cast<uint64_t>(r.Int(3));
  const std::string spec = r.Bytes(0), declared = r.Bytes(2);
  if (received != total) {
    return absl::FailedPreconditionError(
        absl::StrCat("the upload holds ", received, " of its ", total, " bytes: send from offset ", received));
  }
  absl::StatusOr<SqlResult> chunks =
      Q("SELECT data FROM upload_chunks WHERE request_id=?1 ORDER BY \"offset\"", {A::Text(request_id)});
  if (!chunks.ok()) return chunks.status();
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  for (const SqlRow& c : chunks->rows) {
    const std::string data = c.Bytes(0);
    EVP_DigestUpdate(ctx, data.data(), data.size());
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_DigestFinal_ex(ctx, digest, &n);
  EVP_MD_CTX_free(ctx);
  Transaction tx(*db_);
  if (!tx.begun().ok()) return tx.begun();
  if (std::string(reinterpret_cast<const char*>(digest), n) != declared) {
    for (const char* sql :
         {"DELETE FROM uploads WHERE request_id=?1", "DELETE FROM upload_chunks WHERE request_id=?1"}) {
      if (absl::StatusOr<SqlResult> d = Q(sql, {A::Text(request_id)}); !d.ok()) return d.status();
    }
    if (absl::Status s = tx.Commit(); !s.ok()) return s;
    db_->Reclaim();
    return absl::DataLossError(absl::StrCat("the upload's ", total,
                                            " bytes do not match the SHA-256 given in SubmitStart.sha256; they "
                                            "were discarded and no job was queued: upload again from offset 0"));
  }
  // Only while no job is recorded: a replica that committed the same upload meanwhile wins.
  absl::StatusOr<SqlResult> up =
      Q("UPDATE uploads SET job_id=?2 WHERE request_id=?1 AND job_id IS NULL", {A::Text(request_id), A::Text(job_id)});
  if (!up.ok()) return up.status();
  if (up->changed != 1) return absl::AbortedError("another call committed this upload meanwhile: QueryUpload");
  absl::StatusOr<SqlResult> ins =
      Q("INSERT INTO jobs(job_id, request_id, state, spec, upload_bytes, upload_sha256, create_us) "
        "VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7)",
        {A::Text(job_id), A::Text(request_id), A::Int(v1::JOB_STATE_QUEUED), A::Bytes(spec),
         A::Int(static_cast<int64_t>(total)), A::Bytes(declared), A::Int(now_us)});
  if (!ins.ok()) return ins.status();
  if (absl::Status s = tx.Commit(); !s.ok()) return s;
  return job_id;
}

absl::StatusOr<v1::Job> JobStore::GetLocked(const std::string& job_id, bool with_details) {
  absl::StatusOr<SqlResult> q =
      Q(absl::StrCat("SELECT ", kJobColumns, " FROM jobs WHERE job_id=?1"), {A::Text(job_id)});
  if (!q.ok()) return q.status();
  if (q->rows.empty()) return absl::NotFoundError(absl::StrCat("no job '", job_id, "' in this job store"));
  return JobOfRow(q->rows[0], with_details);
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
  std::vector<v1::Job> jobs;
  next->clear();
  absl::StatusOr<SqlResult> q = Q(sql, {A::Int(after_us), A::Text(after_id), A::Int(limit + 1)});
  if (!q.ok()) return jobs;
  for (const SqlRow& r : q->rows) jobs.push_back(JobOfRow(r, /*with_details=*/false));
  if (static_cast<int>(jobs.size()) > limit) {
    jobs.resize(limit);
    *next = PageToken(jobs.back());
  }
  return jobs;
}

std::optional<ClaimedJob> JobStore::Claim(const std::vector<std::string>& skip, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  if (!tx.begun().ok()) return std::nullopt;
  // The rows in `skip` come first in line too: one more than them holds a job to take.
  absl::StatusOr<SqlResult> q =
      Q(absl::StrCat(
            "SELECT job_id, state, request_id, spec FROM jobs WHERE state=?1 OR (state=?2 AND lease_until_us<?3) "
            "ORDER BY create_us, job_id LIMIT ?4",
            db_->ClaimLock()),
        {A::Int(v1::JOB_STATE_QUEUED), A::Int(v1::JOB_STATE_RUNNING), A::Int(now_us),
         A::Int(static_cast<int64_t>(skip.size()) + 1)});
  if (!q.ok()) return std::nullopt;
  const SqlRow* row = nullptr;
  for (const SqlRow& r : q->rows) {
    if (std::find(skip.begin(), skip.end(), r.Bytes(0)) == skip.end()) {
      row = &r;
      break;
    }
  }
  if (row == nullptr) return std::nullopt;
  ClaimedJob claimed;
  claimed.job_id = row->Bytes(0);
  claimed.takeover = row->Int(1) == v1::JOB_STATE_RUNNING;
  claimed.input.spec.ParseFromString(row->Bytes(3));
  absl::StatusOr<SqlResult> up =
      Q("UPDATE jobs SET state=?2, start_us=?3, attempts=attempts+1, event_sequence=event_sequence+1, progress=NULL, "
        "lease_owner=?4, lease_until_us=?5 WHERE job_id=?1",
        {A::Text(claimed.job_id), A::Int(v1::JOB_STATE_RUNNING), A::Int(now_us), A::Text(owner_),
         A::Int(now_us + static_cast<int64_t>(options_.lease_seconds * 1e6))});
  if (!up.ok() || up->changed != 1) return std::nullopt;
  absl::StatusOr<SqlResult> chunks =
      Q("SELECT data FROM upload_chunks WHERE request_id=?1 ORDER BY \"offset\"", {A::Text(row->Bytes(2))});
  if (!chunks.ok()) return std::nullopt;
  for (const SqlRow& c : chunks->rows) claimed.input.upload += c.Bytes(0);
  if (!tx.Commit().ok()) return std::nullopt;
  return claimed;
}

bool JobStore::RenewLease(const std::string& job_id, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<SqlResult> up =
      Q("UPDATE jobs SET lease_until_us=?3 WHERE job_id=?1 AND state=?4 AND lease_owner=?2",
        {A::Text(job_id), A::Text(owner_), A::Int(now_us + static_cast<int64_t>(options_.lease_seconds * 1e6)),
         A::Int(v1::JOB_STATE_RUNNING)});
  // A database out of reach is not a lost lease: the job runs on, and the next renewal tries.
  return !up.ok() || up->changed == 1;
}

void JobStore::Release(const std::string& job_id, bool undo_attempt) {
  std::lock_guard<std::mutex> lock(mu_);
  Q("UPDATE jobs SET state=?3, attempts=attempts-?4, lease_owner='', lease_until_us=0, "
    "event_sequence=event_sequence+1 WHERE job_id=?1 AND state=?5 AND lease_owner=?2",
    {A::Text(job_id), A::Text(owner_), A::Int(v1::JOB_STATE_QUEUED), A::Int(undo_attempt ? 1 : 0),
     A::Int(v1::JOB_STATE_RUNNING)})
      .IgnoreError();
}

void JobStore::SetProgress(const std::string& job_id, const v1::Progress& progress) {
  std::lock_guard<std::mutex> lock(mu_);
  Q("UPDATE jobs SET progress=?2, event_sequence=event_sequence+1 WHERE job_id=?1 AND state=?3 AND lease_owner=?4",
    {A::Text(job_id), A::Bytes(progress.SerializeAsString()), A::Int(v1::JOB_STATE_RUNNING), A::Text(owner_)})
      .IgnoreError();
}

bool JobStore::Succeed(const std::string& job_id, const std::string& result, const v1::Summary& summary,
                       int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  if (!tx.begun().ok()) return false;
  absl::StatusOr<SqlResult> up =
      Q("UPDATE jobs SET state=?2, end_us=?3, summary=?4, result_bytes=?5, result_sha256=?6, lease_until_us=0, "
        "event_sequence=event_sequence+1 WHERE job_id=?1 AND state=?7 AND lease_owner=?8",
        {A::Text(job_id), A::Int(v1::JOB_STATE_SUCCEEDED), A::Int(now_us), A::Bytes(summary.SerializeAsString()),
         A::Int(static_cast<int64_t>(result.size())), A::Bytes(Sha256(result)), A::Int(v1::JOB_STATE_RUNNING),
         A::Text(owner_)});
  if (!up.ok() || up->changed != 1) return false;
  // An earlier attempt's, if any.
  if (!Q("DELETE FROM result_chunks WHERE job_id=?1", {A::Text(job_id)}).ok()) return false;
  for (size_t offset = 0; offset < result.size(); offset += kResultChunkBytes) {
    const std::string_view piece = std::string_view(result).substr(offset, kResultChunkBytes);
    if (!Q("INSERT INTO result_chunks(job_id, \"offset\", data) VALUES(?1, ?2, ?3)",
           {A::Text(job_id), A::Int(static_cast<int64_t>(offset)), A::Bytes(piece)})
             .ok()) {
      return false;
    }
  }
  return tx.Commit().ok();
}

bool JobStore::Fail(const std::string& job_id, const absl::Status& status, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<SqlResult> up =
      Q("UPDATE jobs SET state=?2, end_us=?3, error_code=?4, error_message=?5, lease_until_us=0, "
        "event_sequence=event_sequence+1 WHERE job_id=?1 AND state=?6 AND lease_owner=?7",
        {A::Text(job_id), A::Int(v1::JOB_STATE_FAILED), A::Int(now_us), A::Int(static_cast<int>(status.code())),
         A::Text(std::string(status.message())), A::Int(v1::JOB_STATE_RUNNING), A::Text(owner_)});
  return up.ok() && up->changed == 1;
}

absl::StatusOr<v1::Job> JobStore::Cancel(const std::string& job_id, int64_t now_us) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<SqlResult> up =
      Q("UPDATE jobs SET state=?2, end_us=?3, lease_until_us=0, event_sequence=event_sequence+1 "
        "WHERE job_id=?1 AND state IN (?4, ?5)",
        {A::Text(job_id), A::Int(v1::JOB_STATE_CANCELLED), A::Int(now_us), A::Int(v1::JOB_STATE_QUEUED),
         A::Int(v1::JOB_STATE_RUNNING)});
  if (!up.ok()) return up.status();
  return GetLocked(job_id, /*with_details=*/true);
}

void JobStore::ForgetLocked(const std::vector<std::pair<std::string, std::string>>& jobs_and_requests) {
  if (jobs_and_requests.empty()) return;
  for (const auto& [job_id, request_id] : jobs_and_requests) {
    Transaction tx(*db_);
    if (!tx.begun().ok()) return;
    bool ok = true;
    for (const char* sql : {"DELETE FROM jobs WHERE job_id=?1", "DELETE FROM result_chunks WHERE job_id=?1"}) {
      ok = ok && Q(sql, {A::Text(job_id)}).ok();
    }
    for (const char* sql :
         {"DELETE FROM uploads WHERE request_id=?1", "DELETE FROM upload_chunks WHERE request_id=?1"}) {
      ok = ok && Q(sql, {A::Text(request_id)}).ok();
    }
    if (ok) tx.Commit().IgnoreError();
  }
  db_->Reclaim();
}

absl::Status JobStore::Delete(const std::string& job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<v1::Job> job = GetLocked(job_id, /*with_details=*/false);
  if (!job.ok()) return job.status();
  if (!Ended(job->state())) {
    return absl::FailedPreconditionError(absl::StrCat("job '", job_id, "' is ", v1::JobState_Name(job->state()),
                                                      ": DeleteJob does not cancel; cancel it first (CancelJob)"));
  }
  ForgetLocked({{job_id, job->request_id()}});
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
  // The chunks that hold bytes from `offset`, the first two at most (max_bytes is one chunk).
  absl::StatusOr<SqlResult> q =
      Q("SELECT \"offset\", data FROM result_chunks WHERE job_id=?1 AND \"offset\" + length(data) > ?2 "
        "ORDER BY \"offset\" LIMIT ?3",
        {A::Text(job_id), A::Int(static_cast<int64_t>(offset)),
         A::Int(static_cast<int64_t>(max_bytes / kResultChunkBytes) + 2)});
  if (!q.ok()) return q.status();
  for (const SqlRow& r : q->rows) {
    if (piece.data.size() >= max_bytes) break;
    const uint64_t start = static_cast<uint64_t>(r.Int(0));
    const std::string data = r.Bytes(1);
    const uint64_t from = offset + piece.data.size() - start;
    piece.data.append(data, from, max_bytes - piece.data.size());
  }
  return piece;
}

int JobStore::ExpireEndedBefore(int64_t cutoff_us) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<SqlResult> q =
      Q("SELECT job_id, request_id FROM jobs WHERE end_us != 0 AND end_us < ?1", {A::Int(cutoff_us)});
  if (!q.ok()) return 0;
  std::vector<std::pair<std::string, std::string>> expired;
  for (const SqlRow& r : q->rows) expired.emplace_back(r.Bytes(0), r.Bytes(1));
  ForgetLocked(expired);
  return static_cast<int>(expired.size());
}

bool JobStore::MakeRoom(int64_t bytes, int64_t budget) {
  for (;;) {
    std::lock_guard<std::mutex> lock(mu_);
    if (StoredBytesLocked() + bytes <= budget) return true;
    absl::StatusOr<SqlResult> q = Q("SELECT job_id, request_id FROM jobs WHERE end_us != 0 ORDER BY end_us LIMIT 1");
    if (!q.ok() || q->rows.empty()) return false;
    ForgetLocked({{q->rows[0].Bytes(0), q->rows[0].Bytes(1)}});
  }
}

JobCounts JobStore::Counts() {
  std::lock_guard<std::mutex> lock(mu_);
  JobCounts counts;
  absl::StatusOr<SqlResult> q = Q("SELECT state, COUNT(*), MIN(create_us) FROM jobs GROUP BY state");
  if (!q.ok()) return counts;
  for (const SqlRow& r : q->rows) {
    const int64_t state = r.Int(0);
    if (state < 0 || state >= static_cast<int64_t>(counts.by_state.size())) continue;
    counts.by_state[state] = r.Int(1);
    if (state == v1::JOB_STATE_QUEUED) counts.oldest_queued_us = r.Int(2);
  }
  return counts;
}

}  // namespace meshsmooth::server
