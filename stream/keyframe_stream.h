#pragma once
// rgbdcast stream's producer (the design: docs/streaming.md). run_stream reads the frames (at their own timestamps
// with `realtime`, else as fast as it can), tracks them (keyframes/sequence.h), reduces each keyframe at a budget
// the link carries (stream/keyframe_encoder.h) against the earlier keyframes, writes it to the outbox and wakes the
// sender, refines acknowledged keyframes with spare link capacity, and returns once the sender has delivered
// everything (or stop is asked, or the sender failed for good). With entries or deferred records in the outbox it
// resumes where the outbox stopped, losing and duplicating nothing. The decisions are stream/stream_policy.h's; this
// is the runtime of threads and queues that applies them.
#include <functional>
#include <string>

#include "input/frame_source.h"
#include "keyframes/sequence.h"
#include "pipeline/frame_scene.h"
#include "stream/keyframe_encoder.h"
#include "stream/link_estimator.h"
#include "stream/outbox.h"
#include "stream/sender.h"
#include "stream/stream_policy.h"

namespace rgbdcast::stream {

struct StreamOptions {
  bool realtime = false;
  double fps_without_timestamps = 30;
  FrameReductionOptions reduction;  // the realtime preset; budget_kb is set per keyframe
  SequenceParams sequence;
  BudgetRule budget;
  LatencyRule latency;         // --latency-ms: the budget is also kept to what reaches the view in time
  std::string link_kbps_file;  // --link-kbps-file: re-read on every frame (and while draining); empty: none
  double max_backlog_s = 2.0;
  double coarse_factor = 0.25;
  int reduce_nice = 5;             // --reduce-nice: added to the reduction thread's niceness (0: as the caller)
  bool supersede = true;           // the backlog rule's first step; --keep-every-keyframe turns it off
  size_t max_deferred = 16;        // deferred keyframes waiting at most (beyond: the oldest is dropped)
  double refine_ceiling_kb = 200;  // --refine-kb: a refinement's largest budget (0: no refinements)
  double refine_window_s = 1.0;    // --refine-window-ms: a refinement's longest time on the line
  // --no-refine-while-tracking turns off: refinements between keyframes while tracking, on their own thread at the
  // idle scheduling class (docs/streaming.md).
  bool refine_while_tracking = true;
  FineReduction fine;
  // The entries' times (Unix s, wall-clock facts written into the records); empty: the system's. The sender's
  // SenderParams::unix_s must be the same clock: it measures a keyframe's wait in the outbox from `reduced`. The
  // runtime's steady clock (durations, the keyframe interval, the camera's pacing, the hold-back's deadlines) is the
  // sender's (SenderParams::clock), so that one clock drives the camera, the producer and the link.
  std::function<double()> unix_s;
};

struct StreamProgress {
  size_t frames_done = 0, frames_total = 0;
  size_t keyframes = 0;   // added to the outbox by this run
  double budget_kb = 0;   // of the last keyframe
  double interval_s = 0;  // keyframe interval estimate
  double overhead_s = 0;  // of the last keyframe: the latency rule's time before its POST (estimated)
  std::string tracking;   // the last frame's tracking note
  bool draining = false;  // every frame read; waiting for the sender
  SenderStats sender;
};

struct StreamSummary {
  size_t frames = 0, tracked = 0, dropped = 0;  // dropped: stale frames skipped in realtime
  size_t keyframes = 0;                         // new outbox entries of this run
  size_t covered = 0;                           // keyframes with nothing new (not sent)
  size_t coarsened = 0;
  size_t superseded = 0;        // tracked keyframes deferred: a newer one went first while the link owed too much
  size_t deferred_sent = 0;     // of which reduced later (coarsened) and written to the outbox
  size_t deferred_dropped = 0;  // deferred keyframes dropped (more than max_deferred waited; resumed ones included)
  size_t refined = 0;           // refinements written to the outbox (revisions)
  size_t refined_while_tracking = 0;  // of which made between keyframes, before every frame was read
  size_t refined_ahead = 0;         // of which reduced while their keyframe's POST was out (added once it was answered)
  size_t refined_ahead_redone = 0;  // sized to the cap before any answer, too large for the measured link: made again
  size_t refined_beside_keyframe = 0;  // of the refinements added, reduced beside their keyframe's own reduction
  size_t refined_not_kept = 0;         // refinements reduced but not added: under kRefinementKeepRatio x the bytes
  size_t refine_saturated = 0;  // keyframe revisions not refined: they "fit", so a larger budget gives them again
  size_t cap_changes = 0;       // values taken from --link-kbps-file
  size_t failed = 0;            // keyframes whose reduction or outbox write failed (message in errors)
  bool resumed = false;
  int resumed_at_frame = -1;
  size_t resumed_entries = 0;
  size_t resumed_deferred = 0;       // deferred keyframes reloaded from the outbox's records
  size_t resumed_deferred_sent = 0;  // of which reduced (coarsened) and written to the outbox by this run
  size_t deferred_waiting = 0;       // deferred keyframes still waiting in the outbox's records at the end (a stop)
  double seconds = 0;
  bool stopped = false;  // stop was asked before everything was delivered
  std::vector<std::string> errors;
  SenderStats sender;
  // Is tracking keeping up: per frame read (not the dropped ones), the wall time from the frame being due (or its
  // read starting) to its tracking's end, the camera reader's CPU time to read it (stream/camera_reader.h) and the
  // tracker thread's CPU time to track it; per keyframe, the wall time of its reduction on the reduction thread.
  // Milliseconds.
  std::vector<double> frame_wall_ms, frame_cpu_ms, read_cpu_ms, reduce_ms;
  size_t reduce_queue_max = 0;  // most keyframes waiting for the reduction thread at once
};

struct Percentiles {
  double p50 = 0, p95 = 0;  // linear interpolation between order statistics; 0 for no samples
};
Percentiles percentiles(std::vector<double> values);

// Errors: the sequence's (kInvalidArgument, kEmpty), an outbox entry whose frame cannot be reloaded on resume
// (kNotFound), the sender's fatal error (kUnavailable, e.g. a refused token).
Result<StreamSummary> run_stream(const FrameSource& source, Outbox& outbox, Sender& sender,
                                 const StreamOptions& options,
                                 const std::function<void(const StreamProgress&)>& on_progress,
                                 const std::function<bool()>& should_stop);

}  // namespace rgbdcast::stream
