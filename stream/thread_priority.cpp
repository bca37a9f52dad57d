#include "stream/thread_priority.h"

#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

namespace rgbdcast::stream {

double thread_cpu_ms() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) / 1e6;
}

void renice_this_thread(int increment) {
  if (increment <= 0) return;
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  errno = 0;
  const int now = ::getpriority(PRIO_PROCESS, tid);
  if (errno == 0) ::setpriority(PRIO_PROCESS, tid, std::min(19, now + increment));
}

pid_t idle_this_thread() {
  const auto tid = static_cast<pid_t>(::syscall(SYS_gettid));
  sched_param sp{};
  sp.sched_priority = 0;
  ::sched_setscheduler(tid, SCHED_IDLE, &sp);
  return tid;
}

void back_to_normal(pid_t tid) {
  sched_param sp{};
  sp.sched_priority = 0;
  ::sched_setscheduler(tid, SCHED_OTHER, &sp);
}

}  // namespace rgbdcast::stream
