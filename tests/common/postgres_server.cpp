#include "tests/common/postgres_server.h"

#include <libpq-fe.h>
#include <pwd.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <thread>
#include <vector>

namespace fs = std::filesystem;

namespace rgbdcast::test {
namespace {

// Runs argv as the `postgres` user when this process is root (as itself otherwise), with stdout and stderr into
// `log`. Returns the child's pid, or -1.
pid_t spawn(const std::vector<std::string>& argv, const std::string& log) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  if (::geteuid() == 0) {
    const passwd* pw = ::getpwnam("postgres");
    if (!pw || ::setgid(pw->pw_gid) != 0 || ::setuid(pw->pw_uid) != 0) ::_exit(126);
  }
  // A test killed before it could stop the server takes the server with it: SIGQUIT (immediate shutdown, which
  // ends the server's own children too) when the test's thread dies. Set after setuid, which clears it.
  ::prctl(PR_SET_PDEATHSIG, SIGQUIT);
  if (::getppid() == 1) ::_exit(125);  // the test died before the line above
  ::setsid();  // its own session: a terminal's Ctrl-C reaches the test, which then stops the server itself
  FILE* f = std::freopen(log.c_str(), "a", stdout);
  if (f) ::dup2(::fileno(stdout), 2);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  ::execv(args[0], args.data());
  ::_exit(127);
}

bool exited_within(pid_t pid, double seconds, int* status) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (::waitpid(pid, status, WNOHANG) == pid) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

bool run_sql(const std::string& uri, const std::string& sql) {
  PGconn* c = PQconnectdb(uri.c_str());
  bool ok = PQstatus(c) == CONNECTION_OK;
  if (ok) {
    PGresult* r = PQexec(c, sql.c_str());
    ok = PQresultStatus(r) == PGRES_COMMAND_OK || PQresultStatus(r) == PGRES_TUPLES_OK;
    PQclear(r);
  }
  PQfinish(c);
  return ok;
}

}  // namespace

std::string postgres_bin_dir() {
  const fs::path dir = "/usr/lib/postgresql/15/bin";
  // path / name rather than string + literal: GCC 12's false positive on the latter (top CMakeLists.txt).
  return fs::exists(dir / "initdb") && fs::exists(dir / "postgres") ? dir.string() : "";
}

Result<std::unique_ptr<PostgresServer>> PostgresServer::start() {
  const std::string bin = postgres_bin_dir();
  if (bin.empty()) return make_error(ErrorCode::kUnavailable, "PostgreSQL 15 is not installed (scripts/setup.sh test)");
  char tmpl[] = "/tmp/rgbdcast-pg-XXXXXX";
  if (!::mkdtemp(tmpl)) return make_error(ErrorCode::kIo, "cannot make a folder for PostgreSQL");
  std::unique_ptr<PostgresServer> s(new PostgresServer(tmpl));
  if (::geteuid() == 0) {
    const passwd* pw = ::getpwnam("postgres");
    if (!pw) return make_error(ErrorCode::kUnavailable, "no user 'postgres' to run PostgreSQL as");
    if (::chown(tmpl, pw->pw_uid, pw->pw_gid) != 0) return make_error(ErrorCode::kIo, "cannot chown the folder");
  }
  const pid_t init = spawn({bin + "/initdb", "-D", s->dir_ + "/data", "-A", "trust", "-U", "postgres", "-E", "UTF8",
                            "--no-sync", "--no-instructions"},
                           s->dir_ + "/initdb.log");
  int status = 0;
  if (init < 0 || !exited_within(init, 60.0, &status) || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    if (init > 0) {
      ::kill(init, SIGKILL);
      ::waitpid(init, &status, 0);
    }
    return make_error(ErrorCode::kUnavailable, "initdb failed (see " + s->dir_ + "/initdb.log)");
  }
  if (auto st = s->launch(); !st) return st.error();
  return s;
}

Status PostgresServer::launch() {
  pid_ = spawn({postgres_bin_dir() + "/postgres", "-D", dir_ + "/data", "-k", dir_, "-c", "listen_addresses=", "-c",
                "fsync=off", "-c", "full_page_writes=off"},
               dir_ + "/postgres.log");
  if (pid_ < 0) return make_error(ErrorCode::kUnavailable, "cannot start postgres");
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < end) {
    if (run_sql(uri("postgres"), "SELECT 1")) return ok_status();
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return make_error(ErrorCode::kUnavailable, "postgres exited at start (see " + dir_ + "/postgres.log)");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  stop();
  return make_error(ErrorCode::kUnavailable, "postgres did not answer within 30 s");
}

PostgresServer::~PostgresServer() {
  stop();
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

std::string PostgresServer::uri(const std::string& db) const {
  return "postgresql:///" + db + "?host=" + dir_ + "&user=postgres";
}

Result<std::string> PostgresServer::create_database() {
  const std::string name = "t" + std::to_string(++next_db_);
  if (!run_sql(uri("postgres"), "CREATE DATABASE " + name))
    return make_error(ErrorCode::kUnavailable, "cannot create database " + name);
  return uri(name);
}

Status PostgresServer::restart() {
  if (pid_ > 0) {
    // The postmaster and its children (its process group: spawn() made it a session leader), as a crash of the
    // database's host would end them. Killing the postmaster alone leaves its children attached to the shared
    // memory for a moment, and a postmaster started meanwhile refuses to run.
    ::kill(-pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }
  // A child of the old postmaster still exiting makes the new one exit at start: tried again, for at most 30 s.
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (true) {
    auto st = launch();
    if (st || std::chrono::steady_clock::now() >= end) return st;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
}

void PostgresServer::stop() {
  if (pid_ <= 0) return;
  int status = 0;
  ::kill(pid_, SIGINT);  // fast shutdown: open sessions are ended
  if (!exited_within(pid_, 10.0, &status)) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &status, 0);
  }
  pid_ = -1;
}

PostgresServer* shared_postgres(std::string* why) {
  static std::string reason;
  static std::unique_ptr<PostgresServer> server = [] {
    auto s = PostgresServer::start();
    if (!s) {
      reason = s.error().message;
      return std::unique_ptr<PostgresServer>();
    }
    return std::move(*s);
  }();
  *why = reason;
  return server.get();
}

Result<std::string> fresh_database() {
  std::string why;
  auto* server = shared_postgres(&why);
  if (!server) return make_error(ErrorCode::kUnavailable, why);
  return server->create_database();
}

}  // namespace rgbdcast::test
