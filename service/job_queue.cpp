#include "service/job_queue.h"

#include <algorithm>

namespace rgbdcast::service {

JobQueue::JobQueue(int workers, int capacity, std::function<void()> on_start)
    : workers_(static_cast<size_t>(std::max(1, workers))),
      capacity_(static_cast<size_t>(std::max(0, capacity))),
      on_start_(std::move(on_start)) {
  for (size_t i = 0; i < workers_; ++i) threads_.emplace_back([this] { run(); });
}

JobQueue::~JobQueue() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    queue_.clear();
  }
  cv_.notify_all();
  for (auto& t : threads_) t.join();
}

bool JobQueue::try_submit(std::function<void()> job) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || queue_.size() + running_ >= workers_ + capacity_) {
      ++rejected_;
      return false;
    }
    queue_.push_back(std::move(job));
  }
  cv_.notify_one();
  return true;
}

size_t JobQueue::waiting() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

size_t JobQueue::running() const {
  std::lock_guard lock(mutex_);
  return running_;
}

size_t JobQueue::rejected() const {
  std::lock_guard lock(mutex_);
  return rejected_;
}

void JobQueue::run() {
  if (on_start_) on_start_();
  for (;;) {
    std::function<void()> job;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job = std::move(queue_.front());
      queue_.pop_front();
      ++running_;
    }
    try {
      job();
    } catch (...) {
      // The job reports its own errors; an escaping exception must not end the worker.
    }
    std::lock_guard lock(mutex_);
    --running_;
  }
}

}  // namespace rgbdcast::service
