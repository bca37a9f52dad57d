#pragma once
// libpq, thinly: one connection (PgConnection), results that free themselves (PgResult), parameters as text or as
// binary bytea, and a small pool of connections (PgPool) that replaces a broken one on the next lease. Errors are
// values: kUnavailable when the server cannot be reached or the connection broke (the caller may retry: every
// write of the stores is one transaction), kInternal for any other failed statement, with PostgreSQL's message and
// SQLSTATE.
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "scene/result.h"

struct pg_conn;
struct pg_result;

namespace rgbdcast::pgstore {

// One statement parameter: text (sent as text, PostgreSQL casts it), bytes (sent binary: a bytea), or NULL.
struct PgParam {
  static PgParam text(std::string s);
  static PgParam integer(std::int64_t v) { return text(std::to_string(v)); }
  static PgParam real(double v);
  static PgParam bytes(const std::uint8_t* data, size_t size);
  static PgParam null() {
    PgParam p;
    p.is_null = true;
    return p;
  }
  std::string value;
  const std::uint8_t* data = nullptr;  // binary when set (not owned: alive until the statement ran)
  size_t size = 0;
  bool binary = false;
  bool is_null = false;
};

class PgResult {
 public:
  explicit PgResult(pg_result* r) : r_(r) {}
  PgResult(PgResult&& o) noexcept : r_(o.r_) { o.r_ = nullptr; }
  PgResult& operator=(PgResult&& o) noexcept;
  ~PgResult();
  int rows() const;
  int affected() const;  // rows an INSERT/UPDATE/DELETE touched
  bool is_null(int row, int col) const;
  std::string text(int row, int col) const;  // text-format results
  std::int64_t integer(int row, int col) const;
  double real(int row, int col) const;
  std::vector<std::uint8_t> bytes(int row, int col) const;  // binary-format results (the bytes as stored)

 private:
  pg_result* r_ = nullptr;
};

class PgConnection {
 public:
  // kUnavailable (with libpq's reason) when the server cannot be reached; kInvalidArgument for a malformed URI.
  static Result<std::unique_ptr<PgConnection>> connect(const std::string& uri);
  ~PgConnection();
  PgConnection(const PgConnection&) = delete;
  PgConnection& operator=(const PgConnection&) = delete;

  // One statement with parameters $1..$n; binary_result asks for every column in binary (bytea as raw bytes).
  Result<PgResult> exec(std::string_view sql, const std::vector<PgParam>& params = {}, bool binary_result = false);
  Status run(std::string_view sql, const std::vector<PgParam>& params = {});  // exec, result dropped
  // Several statements without parameters, in one round trip (a migration).
  Status run_script(std::string_view sql);
  bool broken() const;  // the connection is lost: drop it
  pg_conn* raw() { return conn_; }
  // The SQLSTATE of the last failed statement ("23505": unique violation), empty when none.
  const std::string& last_sqlstate() const { return sqlstate_; }

 private:
  explicit PgConnection(pg_conn* c) : conn_(c) {}
  Result<PgResult> finish(pg_result* raw);  // takes the result; an error when the statement failed
  pg_conn* conn_ = nullptr;
  std::string sqlstate_;
};

// Runs f(conn) inside BEGIN ... COMMIT (ROLLBACK when f returns an error or COMMIT fails). f's Status decides.
template <class F>
Status in_transaction(PgConnection& conn, F&& f, std::string_view begin = "BEGIN") {
  if (auto st = conn.run(begin); !st) return st;
  Status st = f(conn);
  if (!st) {
    (void)conn.run("ROLLBACK");
    return st;
  }
  return conn.run("COMMIT");
}

class PgPool {
 public:
  // Opens the first connection now (so a wrong URI or an unreachable server is an error at start); the others as
  // they are needed, up to `size`.
  static Result<std::unique_ptr<PgPool>> open(const std::string& uri, size_t size, double wait_s = 10.0);

  class Lease {
   public:
    Lease(PgPool* pool, std::unique_ptr<PgConnection> c) : pool_(pool), conn_(std::move(c)) {}
    // A moved-from lease owns nothing and gives nothing back: only the last holder returns the connection.
    Lease(Lease&& o) noexcept : pool_(o.pool_), conn_(std::move(o.conn_)) { o.pool_ = nullptr; }
    Lease& operator=(Lease&&) = delete;
    Lease(const Lease&) = delete;
    ~Lease();
    PgConnection* operator->() { return conn_.get(); }
    PgConnection& operator*() { return *conn_; }

   private:
    PgPool* pool_;
    std::unique_ptr<PgConnection> conn_;
  };
  // A connection, waiting at most the pool's wait while all are leased; kUnavailable when none is freed in time
  // or none can be made. Never call it while holding a lease of the same pool whose release this wait needs.
  Result<Lease> lease();
  const std::string& uri() const { return uri_; }
  // SELECT 1 on a pooled connection; a connection lost since its last use (the server restarted) is dropped and the
  // check made once more on a new one, so a readiness probe says whether the database answers now.
  Status ping();

 private:
  PgPool(std::string uri, size_t size, double wait_s) : uri_(std::move(uri)), size_(size), wait_s_(wait_s) {}
  void give_back(std::unique_ptr<PgConnection> c);
  std::string uri_;
  size_t size_;
  double wait_s_;
  std::mutex mutex_;
  std::condition_variable freed_;
  std::vector<std::unique_ptr<PgConnection>> idle_;
  size_t out_ = 0;  // leased now
};

// Whether `text` names a PostgreSQL store (a libpq URI: postgresql:// or postgres://).
bool is_postgres_uri(std::string_view text);

}  // namespace rgbdcast::pgstore
