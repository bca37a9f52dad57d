#pragma once
// A throwaway PostgreSQL 15 cluster for one test program: initdb into a fresh folder under /tmp, then the postmaster
// listening only on a unix socket in that folder (no TCP port), without fsync (a killed server loses nothing the kernel
// holds; commits stay synchronous, so a commit acknowledged before a kill -9 survives it). PostgreSQL refuses to run
// as root, so when the tests run as root both run as the `postgres` user (the folder is given to it). Bounded:
// start() waits at most 30 s for the server to answer; stop() ends exactly the postmaster it started (by its pid:
// SIGINT, a fast shutdown, then SIGKILL after 10 s) and removes the folder; a test that dies takes its server along.
#include <memory>
#include <string>
#include <sys/types.h>

#include "scene/result.h"

namespace rgbdcast::test {

class PostgresServer {
 public:
  // kUnavailable (with the reason) when the binaries are missing or the server does not come up.
  static Result<std::unique_ptr<PostgresServer>> start();
  ~PostgresServer();
  // A libpq URI of database `db` on this server.
  std::string uri(const std::string& db) const;
  // A new empty database with a unique name; returns its URI.
  Result<std::string> create_database();
  // SIGKILL of the postmaster and its children, then a new postmaster on the same data: a crash and a restart of
  // the database.
  Status restart();
  void stop();
  pid_t pid() const { return pid_; }

 private:
  explicit PostgresServer(std::string dir) : dir_(std::move(dir)) {}
  Status launch();
  std::string dir_;
  pid_t pid_ = -1;
  int next_db_ = 0;
};

// The test program's one server, started on first use and stopped when the program exits; null, with the reason in
// *why, when it cannot start.
PostgresServer* shared_postgres(std::string* why);
// A new empty database on that server (its URI); kUnavailable, with the reason, when the server cannot start.
Result<std::string> fresh_database();

// The binaries (Debian's postgresql-15): where initdb and postgres are, or empty when not installed.
std::string postgres_bin_dir();

}  // namespace rgbdcast::test
