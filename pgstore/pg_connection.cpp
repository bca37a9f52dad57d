#include "pgstore/pg_connection.h"

#include <libpq-fe.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace rgbdcast::pgstore {
namespace {

// libpq's messages end with a newline and may span lines: one line for the log and the HTTP error.
std::string one_line(std::string why) {
  while (!why.empty() && (why.back() == '\n' || why.back() == ' ')) why.pop_back();
  for (auto& ch : why)
    if (ch == '\n') ch = ' ';
  return why;
}

}  // namespace

PgParam PgParam::text(std::string s) {
  PgParam p;
  p.value = std::move(s);
  return p;
}

PgParam PgParam::real(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);  // round-trips a double exactly
  return text(buf);
}

PgParam PgParam::bytes(const std::uint8_t* data, size_t size) {
  PgParam p;
  p.data = data;
  p.size = size;
  p.binary = true;
  return p;
}

PgResult& PgResult::operator=(PgResult&& o) noexcept {
  if (this != &o) {
    if (r_) PQclear(r_);
    r_ = o.r_;
    o.r_ = nullptr;
  }
  return *this;
}

PgResult::~PgResult() {
  if (r_) PQclear(r_);
}

int PgResult::rows() const { return PQntuples(r_); }
int PgResult::affected() const {
  const char* n = PQcmdTuples(r_);
  return n && *n ? std::atoi(n) : 0;
}
bool PgResult::is_null(int row, int col) const { return PQgetisnull(r_, row, col) != 0; }
std::string PgResult::text(int row, int col) const {
  return std::string(PQgetvalue(r_, row, col), static_cast<size_t>(PQgetlength(r_, row, col)));
}
std::int64_t PgResult::integer(int row, int col) const { return std::strtoll(PQgetvalue(r_, row, col), nullptr, 10); }
double PgResult::real(int row, int col) const { return std::strtod(PQgetvalue(r_, row, col), nullptr); }
std::vector<std::uint8_t> PgResult::bytes(int row, int col) const {
  const auto* p = reinterpret_cast<const std::uint8_t*>(PQgetvalue(r_, row, col));
  return std::vector<std::uint8_t>(p, p + PQgetlength(r_, row, col));
}

Result<std::unique_ptr<PgConnection>> PgConnection::connect(const std::string& uri) {
  if (!is_postgres_uri(uri))
    return make_error(ErrorCode::kInvalidArgument, "a PostgreSQL store is a libpq URI: postgresql://...");
  // Bounded: 10 s to connect unless the URI says otherwise (the URI comes later, so its connect_timeout wins).
  const char* keys[] = {"connect_timeout", "dbname", nullptr};
  const char* values[] = {"10", uri.c_str(), nullptr};
  PGconn* c = PQconnectdbParams(keys, values, /*expand_dbname=*/1);
  if (!c) return make_error(ErrorCode::kUnavailable, "postgresql: out of memory");
  if (PQstatus(c) != CONNECTION_OK) {
    const std::string why = one_line(PQerrorMessage(c));
    PQfinish(c);
    return make_error(ErrorCode::kUnavailable, "postgresql: cannot connect: " + why);
  }
  // Quiet: NOTICEs (e.g. "relation already exists, skipping") would go to stderr.
  PQsetNoticeProcessor(
      c, [](void*, const char*) {}, nullptr);
  return std::unique_ptr<PgConnection>(new PgConnection(c));
}

PgConnection::~PgConnection() {
  if (conn_) PQfinish(conn_);
}

bool PgConnection::broken() const { return PQstatus(conn_) != CONNECTION_OK; }

Result<PgResult> PgConnection::exec(std::string_view sql, const std::vector<PgParam>& params, bool binary_result) {
  std::vector<const char*> values;
  std::vector<int> lengths, formats;
  for (const auto& p : params) {
    values.push_back(p.is_null ? nullptr : p.binary ? reinterpret_cast<const char*>(p.data) : p.value.c_str());
    lengths.push_back(p.binary ? static_cast<int>(p.size) : 0);
    formats.push_back(p.binary ? 1 : 0);
  }
  const std::string statement(sql);
  PGresult* raw = PQexecParams(conn_, statement.c_str(), static_cast<int>(params.size()), nullptr, values.data(),
                               lengths.data(), formats.data(), binary_result ? 1 : 0);
  return finish(raw);
}

Result<PgResult> PgConnection::finish(pg_result* raw) {
  sqlstate_.clear();
  const ExecStatusType status = raw ? PQresultStatus(raw) : PGRES_FATAL_ERROR;
  std::string why = raw ? PQresultErrorMessage(raw) : PQerrorMessage(conn_);
  if (raw) {
    const char* state = PQresultErrorField(raw, PG_DIAG_SQLSTATE);
    if (state) sqlstate_ = state;
  }
  PgResult owned(raw);
  if (status == PGRES_COMMAND_OK || status == PGRES_TUPLES_OK) return owned;
  why = one_line(std::move(why));
  // Lost connections (class 08, admin shutdown 57P01..57P03) are worth a retry; the rest are errors of the statement.
  const bool lost = broken() || sqlstate_.rfind("08", 0) == 0 || sqlstate_.rfind("57P0", 0) == 0;
  return make_error(lost ? ErrorCode::kUnavailable : ErrorCode::kInternal,
                    "postgresql: " + why + (sqlstate_.empty() ? "" : " (SQLSTATE " + sqlstate_ + ")"));
}

Status PgConnection::run_script(std::string_view sql) {
  const std::string text(sql);
  auto r = finish(PQexec(conn_, text.c_str()));
  if (!r) return r.error();
  return ok_status();
}

Status PgConnection::run(std::string_view sql, const std::vector<PgParam>& params) {
  auto r = exec(sql, params);
  if (!r) return r.error();
  return ok_status();
}

Result<std::unique_ptr<PgPool>> PgPool::open(const std::string& uri, size_t size, double wait_s) {
  auto first = PgConnection::connect(uri);
  if (!first) return first.error();
  std::unique_ptr<PgPool> pool(new PgPool(uri, size == 0 ? 1 : size, wait_s));
  pool->idle_.push_back(std::move(*first));
  return pool;
}

PgPool::Lease::~Lease() {
  if (pool_) pool_->give_back(std::move(conn_));
}

Result<PgPool::Lease> PgPool::lease() {
  std::unique_lock lock(mutex_);
  if (!freed_.wait_for(lock, std::chrono::duration<double>(wait_s_), [&] { return !idle_.empty() || out_ < size_; }))
    return make_error(ErrorCode::kUnavailable, "postgresql: every connection of the pool is busy");
  ++out_;
  std::unique_ptr<PgConnection> c;
  if (!idle_.empty()) {
    c = std::move(idle_.back());
    idle_.pop_back();
  }
  lock.unlock();  // the lease is made unlocked: its moves and, on an error, its release take the lock
  if (c && !c->broken()) return Lease(this, std::move(c));
  c.reset();
  auto made = PgConnection::connect(uri_);  // a new one, or one in place of a broken one
  if (!made) {
    {
      std::lock_guard relock(mutex_);
      --out_;
    }
    freed_.notify_one();
    return made.error();
  }
  return Lease(this, std::move(*made));
}

void PgPool::give_back(std::unique_ptr<PgConnection> c) {
  {
    std::lock_guard lock(mutex_);
    --out_;
    if (c && !c->broken()) idle_.push_back(std::move(c));
  }
  freed_.notify_one();
}

Status PgPool::ping() {
  Status st = ok_status();
  for (int attempt = 0; attempt < 2; ++attempt) {
    auto conn = lease();
    if (!conn) return conn.error();
    st = (*conn)->run("SELECT 1");
    if (st || st.error().code != ErrorCode::kUnavailable) return st;
  }
  return st;
}

bool is_postgres_uri(std::string_view text) {
  return text.rfind("postgresql://", 0) == 0 || text.rfind("postgres://", 0) == 0;
}

}  // namespace rgbdcast::pgstore
