#include "pgstore/pg_mission_listener.h"

#include <libpq-fe.h>
#include <poll.h>

#include <chrono>

#include "pgstore/pg_mission_store.h"
#include "pgstore/pg_schema.h"

namespace rgbdcast::pgstore {

PgMissionListener::PgMissionListener(std::string uri, PgMissionStore& store, double poll_interval_s)
    : uri_(std::move(uri)), store_(store), poll_interval_s_(poll_interval_s) {
  thread_ = std::thread([this] { run(); });
}

PgMissionListener::~PgMissionListener() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void PgMissionListener::pause(double seconds) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return stopping_.load(); });
}

void PgMissionListener::run() {
  using Clock = std::chrono::steady_clock;
  while (!stopping_) {
    auto conn = PgConnection::connect(uri_);
    if (!conn) {
      pause(0.5);
      continue;
    }
    if (!(*conn)->run(std::string("LISTEN ") + kMissionChannel) || !store_.catch_up(**conn)) {
      pause(0.5);
      continue;
    }
    connected_ = true;
    auto last_catch_up = Clock::now();
    PGconn* raw = (*conn)->raw();
    while (!stopping_ && !(*conn)->broken()) {
      pollfd p{PQsocket(raw), POLLIN, 0};
      // Short waits so that stopping is prompt; the poll interval bounds how late a missed hint is made up for.
      const int ready = ::poll(&p, 1, 100);
      bool hinted = false;
      if (ready > 0) {
        if (PQconsumeInput(raw) == 0) break;
        while (PGnotify* n = PQnotifies(raw)) {
          hinted = true;
          PQfreemem(n);
        }
      }
      const bool due = std::chrono::duration<double>(Clock::now() - last_catch_up).count() >= poll_interval_s_;
      if (hinted || due) {
        if (!store_.catch_up(**conn)) break;
        last_catch_up = Clock::now();
      }
    }
    connected_ = false;
    if (!stopping_) pause(0.2);
  }
}

}  // namespace rgbdcast::pgstore
