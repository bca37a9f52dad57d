#pragma once
// Linux thread scheduling for the stream's threads: niceness and the scheduling class are per thread, and threads
// created later by a thread inherit them. Failures are ignored (the stream runs as before, only less polite).
#include <sys/types.h>

namespace rgbdcast::stream {

// CPU time of the calling thread, ms.
double thread_cpu_ms();
// Raises the calling thread's niceness by `increment` (at most 19); nothing for increment <= 0.
void renice_this_thread(int increment);
// The idle scheduling class (SCHED_IDLE) for the calling thread: it runs on a core nothing else wants. Returns the
// thread's id, for back_to_normal.
pid_t idle_this_thread();
// The normal class again (its niceness kept) for thread `tid`.
void back_to_normal(pid_t tid);

}  // namespace rgbdcast::stream
