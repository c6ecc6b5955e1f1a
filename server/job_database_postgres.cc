// The job store's rows in PostgreSQL (libpqxx): one database that any number of meshsmoothd
// replicas share. Meshes go in bytea rows of at most 1 MiB, as in SQLite, rather than in large
// objects: a chunk row commits with the count of bytes held and a job's state in one
// transaction, a deleted job takes its bytes with it (a large object outlives its row unless
// unlinked), and pg_dump, replication and the row-level permissions treat them as any row.
//
// Parameters go as text (a bytea's as its hex form), results come back as text (a bytea's
// unescaped here). One connection; the store calls it under its own mutex. A connection that
// broke between statements is opened again once before the statement fails.
#include <pqxx/pqxx>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "server/job_database.h"

namespace meshsmooth::server {
namespace {

// Held while the schema is made: replicas starting together would otherwise race on
// CREATE TABLE IF NOT EXISTS (a unique violation in PostgreSQL's catalog).
constexpr int64_t kSchemaLock = 0x6d657368736d6f6f;  // "meshsmoo"

constexpr pqxx::oid kByteaOid = 17;

// ?1 .. ?N as $1 .. $N (the statements hold no '?' of their own).
std::string Dollars(std::string_view sql) {
  std::string out(sql);
  for (char& c : out) {
    if (c == '?') c = '$';
  }
  return out;
}

// Without the password: the URI as an error message may show it.
std::string HostOf(const std::string& uri) {
  const size_t at = uri.rfind('@');
  const size_t scheme = uri.find("://");
  return at == std::string::npos ? uri : absl::StrCat(uri.substr(0, scheme + 3), "...", uri.substr(at));
}

class PostgresJobDatabase final : public JobDatabase {
 public:
  explicit PostgresJobDatabase(std::string uri) : uri_(std::move(uri)) {}

  absl::Status Open() {
    try {
      conn_ = std::make_unique<pqxx::connection>(uri_);
      pqxx::work w(*conn_);
      w.exec_params("SELECT pg_advisory_xact_lock($1)", kSchemaLock);
      w.exec(JobStoreSchema("BYTEA", "BIGINT"));
      w.commit();
    } catch (const std::exception& e) {
      return absl::UnavailableError(
          absl::StrCat("cannot open the job store in PostgreSQL at ", HostOf(uri_), ": ", e.what()));
    }
    return absl::OkStatus();
  }

  absl::StatusOr<SqlResult> Run(std::string_view sql, const std::vector<SqlArg>& args) override {
    std::vector<std::string> params;
    params.reserve(args.size());
    for (const SqlArg& a : args) {
      if (a.kind == SqlArg::Kind::kInt) {
        params.push_back(std::to_string(a.number));
      } else if (a.kind == SqlArg::Kind::kText) {
        params.push_back(a.bytes);
      } else {
        params.push_back(absl::StrCat("\\x", absl::BytesToHexString(a.bytes)));
      }
    }
    const std::string query = Dollars(sql);
    for (int attempt = 0;; ++attempt) {
      try {
        pqxx::result r;
        if (tx_) {
          r = tx_->exec_params(query, pqxx::prepare::make_dynamic_params(params));
        } else {
          pqxx::nontransaction n(*conn_);
          r = n.exec_params(query, pqxx::prepare::make_dynamic_params(params));
        }
        return ToResult(r);
      } catch (const pqxx::broken_connection& e) {
        if (tx_ || attempt > 0) return Failed(e, sql);
        if (absl::Status s = Reconnect(); !s.ok()) return s;
      } catch (const std::exception& e) {
        return Failed(e, sql);
      }
    }
  }

  absl::Status Begin() override {
    for (int attempt = 0;; ++attempt) {
      try {
        tx_ = std::make_unique<pqxx::work>(*conn_);
        return absl::OkStatus();
      } catch (const pqxx::broken_connection& e) {
        if (attempt > 0) return Failed(e, "BEGIN");
        if (absl::Status s = Reconnect(); !s.ok()) return s;
      } catch (const std::exception& e) {
        return Failed(e, "BEGIN");
      }
    }
  }

  absl::Status Commit() override {
    std::unique_ptr<pqxx::work> tx = std::move(tx_);
    if (!tx) return absl::InternalError("job store: COMMIT outside a transaction");
    try {
      tx->commit();
    } catch (const std::exception& e) {
      return Failed(e, "COMMIT");
    }
    return absl::OkStatus();
  }

  void Rollback() override {
    std::unique_ptr<pqxx::work> tx = std::move(tx_);
    if (!tx) return;
    try {
      tx->abort();
    } catch (const std::exception&) {  // the connection broke: PostgreSQL rolls back on its own
    }
  }

  const char* ClaimLock() const override { return " FOR UPDATE SKIP LOCKED"; }
  bool shared() const override { return true; }

 private:
  SqlResult ToResult(const pqxx::result& r) {
    SqlResult out;
    out.changed = static_cast<int64_t>(r.affected_rows());
    for (const pqxx::row& row : r) {
      SqlRow& o = out.rows.emplace_back();
      for (const pqxx::field& f : row) {
        if (f.is_null()) {
          o.cells.emplace_back(std::nullopt);
        } else if (f.type() == kByteaOid) {
          o.cells.emplace_back(conn_->unesc_raw(f.c_str()));
        } else {
          o.cells.emplace_back(std::string(f.c_str(), f.size()));
        }
      }
    }
    return out;
  }

  absl::Status Reconnect() {
    try {
      conn_ = std::make_unique<pqxx::connection>(uri_);
    } catch (const std::exception& e) {
      return absl::UnavailableError(absl::StrCat("job store: PostgreSQL at ", HostOf(uri_), ": ", e.what()));
    }
    return absl::OkStatus();
  }

  absl::Status Failed(const std::exception& e, std::string_view sql) {
    return absl::UnavailableError(
        absl::StrCat("job store: PostgreSQL: ", e.what(), " in ", std::string(sql.substr(0, 80))));
  }

  const std::string uri_;
  std::unique_ptr<pqxx::connection> conn_;
  std::unique_ptr<pqxx::work> tx_;  // the open transaction, if any
};

}  // namespace

absl::StatusOr<std::unique_ptr<JobDatabase>> OpenPostgresJobDatabase(const std::string& uri) {
  auto db = std::make_unique<PostgresJobDatabase>(uri);
  if (absl::Status s = db->Open(); !s.ok()) return s;
  return db;
}

}  // namespace meshsmooth::server
