#pragma once
// A small pool of threads fed by one bounded queue, for work too heavy for an HTTP thread (the reduction of an
// uploaded frame: seconds of CPU and hundreds of MB). Contract: try_submit() returns false at once when `capacity`
// jobs are already waiting and every worker is busy (the HTTP layer answers 503 with Retry-After); a job that throws
// is caught and counted, never kills the worker. Each worker runs `on_start` first (for example to cap OpenMP's
// threads for itself). The destructor finishes the running jobs and drops the waiting ones (their std::function
// is destroyed, so a promise they hold reports broken_promise).
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace rgbdcast::service {

class JobQueue {
 public:
  JobQueue(int workers, int capacity, std::function<void()> on_start = {});
  ~JobQueue();
  JobQueue(const JobQueue&) = delete;
  JobQueue& operator=(const JobQueue&) = delete;

  bool try_submit(std::function<void()> job);
  size_t waiting() const;  // jobs queued, not yet started
  size_t running() const;
  size_t rejected() const;  // since start

 private:
  void run();
  const size_t workers_, capacity_;
  std::function<void()> on_start_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> queue_;
  size_t running_ = 0, rejected_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace rgbdcast::service
