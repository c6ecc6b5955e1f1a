// Where the job store (server/job_store.h) keeps its rows: one SQL database behind a small
// interface, so that the store's logic (states, leases, chunks, retention) is written once and
// runs on either of two databases:
//   SQLite (job_database_sqlite.cc): a file under a directory, one process at a time;
//   PostgreSQL (job_database_postgres.cc): a server that any number of replicas share.
//
// The store writes each statement once for both: parameters ?1 .. ?N (the PostgreSQL side sends
// them as $1 .. $N), the columns named "offset" quoted, functions both know (length, COALESCE,
// SUM, MIN, COUNT). What differs lives here: the schema's types, how a write transaction starts,
// the row lock a claim takes, what gives deleted pages back.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace meshsmooth::server {

// One parameter of a statement.
struct SqlArg {
  enum class Kind { kText, kInt, kBytes };
  Kind kind = Kind::kText;
  std::string bytes;   // kText, kBytes
  int64_t number = 0;  // kInt

  static SqlArg Text(std::string_view v) { return {Kind::kText, std::string(v), 0}; }
  static SqlArg Bytes(std::string_view v) { return {Kind::kBytes, std::string(v), 0}; }
  static SqlArg Int(int64_t v) { return {Kind::kInt, {}, v}; }
};

// One row of a result: each column's bytes (an integer as its decimal digits), nullopt for NULL.
struct SqlRow {
  std::vector<std::optional<std::string>> cells;
  // The column as an integer; 0 for NULL.
  int64_t Int(size_t i) const { return cells[i] ? std::strtoll(cells[i]->c_str(), nullptr, 10) : 0; }
  // The column's bytes; empty for NULL.
  std::string Bytes(size_t i) const { return cells[i].value_or(std::string()); }
};

struct SqlResult {
  std::vector<SqlRow> rows;
  int64_t changed = 0;  // rows an INSERT, UPDATE or DELETE changed
};

class JobDatabase {
 public:
  virtual ~JobDatabase() = default;
  // Runs one statement; Internal (SQLite) or Unavailable (PostgreSQL) with the database's message.
  virtual absl::StatusOr<SqlResult> Run(std::string_view sql, const std::vector<SqlArg>& args) = 0;
  // A write transaction: Begin, statements, then Commit or Rollback. Statements outside one
  // commit each on their own.
  virtual absl::Status Begin() = 0;
  virtual absl::Status Commit() = 0;
  virtual void Rollback() = 0;
  // Appended to the SELECT that claims a job: " FOR UPDATE SKIP LOCKED" where other processes
  // claim at the same time (a replica skips the rows another one is taking), "" where none does.
  virtual const char* ClaimLock() const = 0;
  // True when other processes share the database: a job RUNNING at open may be running on one
  // of them; false when this process owns it (a job RUNNING at open was left by a dead one).
  virtual bool shared() const = 0;
  // Gives the pages of deleted rows back to the file system where the database does not do it
  // on its own (SQLite's incremental vacuum).
  virtual void Reclaim() {}
};

// The store's tables and indexes, the one text both databases make (job_database.cc), with their
// type for bytes (BLOB, BYTEA) and for 64-bit integers (INTEGER, BIGINT).
std::string JobStoreSchema(std::string_view bytes_type, std::string_view int64_type);

// DIR/jobs.sqlite3, made with its directory when missing; the exclusive lock DIR/lock held while
// it is open. FailedPrecondition when the directory cannot be made or another process holds it;
// Internal for a database SQLite cannot open.
absl::StatusOr<std::unique_ptr<JobDatabase>> OpenSqliteJobDatabase(const std::string& dir);

// A connection to the PostgreSQL server at `uri` (postgresql://user:password@host:port/db), its
// tables made when missing. Unavailable naming the host when it cannot connect.
absl::StatusOr<std::unique_ptr<JobDatabase>> OpenPostgresJobDatabase(const std::string& uri);

// True for a PostgreSQL connection URI (postgresql:// or postgres://), false for a directory.
inline bool IsPostgresUri(std::string_view where) {
  return where.rfind("postgresql://", 0) == 0 || where.rfind("postgres://", 0) == 0;
}

}  // namespace meshsmooth::server
