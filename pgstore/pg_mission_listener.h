#pragma once
// The thread that keeps a replica's missions current (pgstore/pg_mission_store.h): on its own direct connection (a
// LISTEN through a transaction-pooling proxy delivers nothing) it LISTENs on kMissionChannel and, on each
// notification, after each (re)connect and at least every poll interval, applies every change the replica has not
// applied yet (PgMissionStore::catch_up). A lost connection is made again after a pause; nothing is missed, because
// the catch-up is by change number, never by notification.
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace rgbdcast::pgstore {

class PgMissionStore;

class PgMissionListener {
 public:
  PgMissionListener(std::string uri, PgMissionStore& store, double poll_interval_s);
  ~PgMissionListener();  // stops and joins the thread
  PgMissionListener(const PgMissionListener&) = delete;
  PgMissionListener& operator=(const PgMissionListener&) = delete;
  bool connected() const { return connected_.load(); }

 private:
  void run();
  void pause(double seconds);  // returns early when stopping
  std::string uri_;
  PgMissionStore& store_;
  double poll_interval_s_;
  std::atomic<bool> stopping_{false}, connected_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
  std::thread thread_;
};

}  // namespace rgbdcast::pgstore
