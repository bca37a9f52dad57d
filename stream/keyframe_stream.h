#pragma once
// rgbdcast stream's producer: reads frames (at their own timestamps with `realtime`, else as fast as it can), tracks
// them with keyframes/sequence.h, reduces each keyframe with the one frame -> scene call (pipeline/frame_scene.h,
// realtime preset, a byte budget from the link), writes it to the outbox and wakes the sender; then waits until the
// sender has delivered everything (or stop is asked).
//
// Delta keyframes: each keyframe is reduced with the earlier keyframes as coverage views, so the triangles they
// already cover are dropped (reduction/coverage_filter.h, as `reduce --sequence` does). A keyframe with nothing new
// is not sent (counted in `covered`). The GLB holds the mesh in the keyframe's camera frame; its world pose goes in
// the POST (see stream/uplink.h).
//
// Realtime: frame i is due at start + (t_i - t_first) (t from the source's timestamps, else i / fps); the reader
// waits for it, and a frame whose successor is already due when its turn comes is dropped, as a live camera's
// driver would replace it (the record says "dropped"). "captured" is the due time (Unix s); without realtime it is
// the time the frame was read.
//
// Budget: the smaller of the rate rule and the latency rule (stream/link_estimator.h). The latency rule's overhead
// is what is known when the keyframe's pose is: the seconds since its capture (reading, tracking), plus the
// earlier keyframes' reduction time (SmoothedDuration: mean + 2 mean deviations; 0.3 s before the first, about what
// one took on 2 busy cores) and their smoothed wait in the outbox (Sender::queue_wait_s); until a POST was
// acknowledged, also LatencyRule::first_post_fixed_s (the initial estimate knows no round trip). Each outbox entry keeps its times (tracked, reduced, post_started) so a benchmark can
// say where a keyframe's latency went.
//
// Backlog rule (the link cannot carry what is queued): after each new keyframe, when the pending bytes need more
// than max(max_backlog_s, 2 x the keyframe interval) at the current estimate, the older never-attempted keyframes
// are coarsened, oldest first, until the backlog fits: each is re-reduced once (same frame, same coverage views,
// the same single call) to coarse_factor x its budget (not below the budget floor) and replaces its outbox entry
// when smaller. Nothing is dropped: a dropped keyframe would leave a hole that later deltas rely on it to cover.
// The newest keyframe is never coarsened, and the sender posts newest first.
//
// Resume: with entries in the outbox, tracking restarts at the last keyframe's frame, whose pose (from the outbox)
// anchors the new run's poses in the same world; that frame is not sent again; sequence numbers continue; the
// earlier keyframes' frames are reloaded as coverage views. Pending entries are posted as usual (a re-post of a
// stored one is answered 200 by the server's idempotency).
#include <functional>
#include <string>

#include "input/frame_source.h"
#include "keyframes/sequence.h"
#include "pipeline/frame_scene.h"
#include "stream/link_estimator.h"
#include "stream/outbox.h"
#include "stream/sender.h"

namespace rgbdcast::stream {

struct StreamOptions {
  bool realtime = false;
  double fps_without_timestamps = 30;
  FrameReductionOptions reduction;  // the realtime preset; budget_kb is set per keyframe
  SequenceParams sequence;
  BudgetRule budget;
  LatencyRule latency;              // --latency-ms: the budget is also kept to what reaches the view in time
  std::string link_kbps_file;       // --link-kbps-file: re-read on every frame (and while draining); empty: none
  double max_backlog_s = 2.0;
  double coarse_factor = 0.25;
};

struct StreamProgress {
  size_t frames_done = 0, frames_total = 0;
  size_t keyframes = 0;          // added to the outbox by this run
  double budget_kb = 0;          // of the last keyframe
  double interval_s = 0;         // keyframe interval estimate
  double overhead_s = 0;         // of the last keyframe: the latency rule's time before its POST (estimated)
  std::string tracking;          // the last frame's tracking note
  bool draining = false;         // every frame read; waiting for the sender
  SenderStats sender;
};

struct StreamSummary {
  size_t frames = 0, tracked = 0, dropped = 0;  // dropped: stale frames skipped in realtime
  size_t keyframes = 0;       // new outbox entries of this run
  size_t covered = 0;         // keyframes with nothing new (not sent)
  size_t coarsened = 0;
  size_t cap_changes = 0;     // values taken from --link-kbps-file
  size_t failed = 0;          // keyframes whose reduction or outbox write failed (message in errors)
  bool resumed = false;
  int resumed_at_frame = -1;
  size_t resumed_entries = 0;
  double seconds = 0;
  bool stopped = false;       // stop was asked before everything was delivered
  std::vector<std::string> errors;
  SenderStats sender;
};

// Errors: the sequence's (kInvalidArgument, kEmpty), an outbox entry whose frame cannot be reloaded on resume
// (kNotFound), the sender's fatal error (kUnavailable, e.g. a refused token).
Result<StreamSummary> run_stream(const FrameSource& source, Outbox& outbox, Sender& sender,
                                 const StreamOptions& options,
                                 const std::function<void(const StreamProgress&)>& on_progress,
                                 const std::function<bool()>& should_stop);

}  // namespace rgbdcast::stream
