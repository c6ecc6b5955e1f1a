// The job store's rows in SQLite: DIR/jobs.sqlite3, one process at a time (DIR/lock).
//
// WAL with synchronous=FULL: a committed transaction survives a SIGKILL and a power cut.
// auto_vacuum=INCREMENTAL gives the pages of deleted bytes back to the file system (Reclaim).
// One connection; the store calls it under its own mutex.
#include <fcntl.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "server/job_database.h"

namespace meshsmooth::server {
namespace {

// Columns added after the first release of the store: added to a database made before them.
constexpr const char* kAddedColumns[] = {
    "ALTER TABLE jobs ADD COLUMN lease_owner TEXT NOT NULL DEFAULT ''",
    "ALTER TABLE jobs ADD COLUMN lease_until_us INTEGER NOT NULL DEFAULT 0",
};

class SqliteJobDatabase final : public JobDatabase {
 public:
  ~SqliteJobDatabase() override {
    if (db_ != nullptr) sqlite3_close_v2(db_);
    if (lock_fd_ >= 0) close(lock_fd_);
  }

  absl::Status Open(const std::string& dir) {
    if (mkdir(dir.c_str(), 0750) != 0 && errno != EEXIST) {
      return absl::FailedPreconditionError(absl::StrCat("cannot make the job store ", dir, ": ", std::strerror(errno)));
    }
    const std::string lock = dir + "/lock";
    lock_fd_ = open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0640);
    if (lock_fd_ < 0) {
      return absl::FailedPreconditionError(absl::StrCat("cannot open ", lock, ": ", std::strerror(errno)));
    }
    if (flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
      return absl::FailedPreconditionError(
          absl::StrCat("the job store ", dir, " is in use by another meshsmoothd (one process per store)"));
    }
    const std::string path = dir + "/jobs.sqlite3";
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                        nullptr) != SQLITE_OK) {
      return absl::InternalError(absl::StrCat("cannot open the job store's database ", path, ": ",
                                              db_ ? sqlite3_errmsg(db_) : "out of memory"));
    }
    // auto_vacuum takes effect only before the first table exists.
    for (const char* pragma : {"PRAGMA auto_vacuum=INCREMENTAL", "PRAGMA journal_mode=WAL", "PRAGMA synchronous=FULL",
                               "PRAGMA busy_timeout=5000"}) {
      if (absl::Status s = Exec(pragma); !s.ok()) return s;
    }
    if (absl::Status s = Exec(JobStoreSchema("BLOB", "INTEGER").c_str()); !s.ok()) return s;
    for (const char* alter : kAddedColumns) Exec(alter).IgnoreError();  // "duplicate column" once added
    return absl::OkStatus();
  }

  absl::StatusOr<SqlResult> Run(std::string_view sql, const std::vector<SqlArg>& args) override {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db_, sql.data(), static_cast<int>(sql.size()), &s, nullptr) != SQLITE_OK) {
      return Error(sql);
    }
    for (size_t i = 0; i < args.size(); ++i) {
      const SqlArg& a = args[i];
      const int at = static_cast<int>(i) + 1;
      if (a.kind == SqlArg::Kind::kInt) {
        sqlite3_bind_int64(s, at, a.number);
      } else if (a.kind == SqlArg::Kind::kText) {
        sqlite3_bind_text(s, at, a.bytes.data(), static_cast<int>(a.bytes.size()), SQLITE_TRANSIENT);
      } else {
        sqlite3_bind_blob64(s, at, a.bytes.data(), a.bytes.size(), SQLITE_TRANSIENT);
      }
    }
    SqlResult out;
    int rc;
    while ((rc = sqlite3_step(s)) == SQLITE_ROW) {
      SqlRow& row = out.rows.emplace_back();
      for (int c = 0, n = sqlite3_column_count(s); c < n; ++c) {
        switch (sqlite3_column_type(s, c)) {
          case SQLITE_NULL:
            row.cells.emplace_back(std::nullopt);
            break;
          case SQLITE_INTEGER:
            row.cells.emplace_back(std::to_string(sqlite3_column_int64(s, c)));
            break;
          default: {
            const void* p = sqlite3_column_blob(s, c);
            row.cells.emplace_back(p == nullptr ? std::string()
                                                : std::string(static_cast<const char*>(p), sqlite3_column_bytes(s, c)));
          }
        }
      }
    }
    sqlite3_finalize(s);
    if (rc != SQLITE_DONE) return Error(sql);
    out.changed = sqlite3_changes(db_);
    return out;
  }

  absl::Status Begin() override { return Exec("BEGIN IMMEDIATE"); }
  absl::Status Commit() override { return Exec("COMMIT"); }
  void Rollback() override { Exec("ROLLBACK").IgnoreError(); }
  const char* ClaimLock() const override { return ""; }
  bool shared() const override { return false; }

  void Reclaim() override {
    // The freed pages back to the file system: the WAL's into the database, then its free list.
    Exec("PRAGMA wal_checkpoint(TRUNCATE)").IgnoreError();
    Exec("PRAGMA incremental_vacuum").IgnoreError();
    Exec("PRAGMA wal_checkpoint(TRUNCATE)").IgnoreError();
  }

 private:
  absl::Status Exec(const char* sql) {
    char* err = nullptr;
    if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
      absl::Status s = absl::InternalError(absl::StrCat("job store: ", err ? err : "error", " in ", sql));
      sqlite3_free(err);
      return s;
    }
    return absl::OkStatus();
  }

  absl::Status Error(std::string_view sql) {
    return absl::InternalError(absl::StrCat("job store: ", sqlite3_errmsg(db_), " in ", std::string(sql)));
  }

  sqlite3* db_ = nullptr;
  int lock_fd_ = -1;
};

}  // namespace

absl::StatusOr<std::unique_ptr<JobDatabase>> OpenSqliteJobDatabase(const std::string& dir) {
  auto db = std::make_unique<SqliteJobDatabase>();
  if (absl::Status s = db->Open(dir); !s.ok()) return s;
  return db;
}

}  // namespace meshsmooth::server
