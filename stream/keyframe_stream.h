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
// Reading: a camera reader thread (stream/camera_reader.h) reads the frames one ahead of the tracker; in realtime at
// their own timestamps, replacing a frame the tracker did not take in time, as a live camera's driver does (the
// record says "dropped"). "captured" is the due time (Unix s); without realtime it is the time the frame's read
// started.
//
// Threads: tracking runs on the caller's thread and only hands each keyframe (its frame, pose and times) to a
// reduction thread, which reduces keyframes in order, writes them to the outbox and runs the backlog rule; that
// thread (and the workers the reduction starts, which inherit it) runs at `reduce_nice` above the caller, so that
// on a busy machine the tracker keeps reading the camera while a keyframe is being reduced (before, a 0.2-0.4 s
// reduction on the tracker's thread made the realtime reader drop the frames due meanwhile). Keyframes wait in an
// unbounded queue for it, in order. Without realtime there is no camera to keep up with, and a tracker running flat
// out beside the reduction only slows it (measured: 0.15 s became 0.66 s at load 14), so the tracker waits for each
// reduction to end (not while a keyframe is held back for the link, below). When stop is asked, keyframes still queued are not reduced:
// they never reached the outbox, and a resumed run tracks their frames again (they lie after the resume point,
// below); deferred ones wait in their records.
//
// Budget: the smaller of the rate rule and the latency rule (stream/link_estimator.h), both on the POST model (line
// rate and fixed cost per POST, Sender::line_kbps / post_fixed_s). The latency rule's overhead
// is what is known when the keyframe's reduction starts: the seconds since its capture (reading, tracking, the
// reduction queue), plus the
// earlier keyframes' reduction time (SmoothedDuration: mean + 2 mean deviations; 0.3 s before the first, about what
// one took on 2 busy cores) and their smoothed wait in the outbox (Sender::queue_wait_s); until a POST was
// acknowledged, also LatencyRule::first_post_fixed_s (the initial estimate knows no round trip). Each outbox entry keeps its times (tracked, reduced, post_started) so a benchmark can
// say where a keyframe's latency went.
//
// Backlog rule (the link cannot carry what is queued), in two steps:
// - Newest first, older ones deferred (on unless `supersede` is false): the next tracked keyframe is reduced only
//   once what the sender owes (Sender::owed_s: the time left on its paced line plus the pending first revisions not
//   yet started, at the estimate) is no more than the keyframe's expected reduction time (SmoothedDuration below, at
//   least 0.1 s): reduced any earlier, it would only wait for the line, ageing. Until then it waits, and when a newer
//   keyframe is tracked meanwhile, the newer one takes its place and the older one is deferred (counted in
//   `superseded`). Once the link has room, the newest waiting keyframe is reduced first (at the usual budget), then
//   the deferred ones, newest first, each coarsened: coarse_factor x the rate rule's budget (not below the floor),
//   each again only once the link owes no more than a reduction takes. So keyframes enter the outbox no faster than
//   the link carries them, the newest goes first (the sender posts by capture time), and over an outage no keyframe
//   is lost: every one reaches the mission, the older ones coarser. A deferred keyframe gets a higher seq than the
//   newer one reduced before it, and is reduced against it (its delta drops what the newer one covers). At most
//   max_deferred wait; beyond that the oldest is dropped (counted in `deferred_dropped`): a backlog of that many is
//   not one the link will carry while the robot is still moving. Entries already in the outbox are never dropped: later
//   deltas rely on their surface, and the server may hold them. Each deferred keyframe is persisted as a record in
//   the outbox's folder (Outbox::defer: frame index, timestamp, world pose, capture and tracking times; no seq, which
//   is given when it is reduced), written by the reduction thread as it defers it and removed when it is added to
//   the outbox (by Outbox::add, in the same call), when its reduction leaves nothing to add, or when it is dropped.
// - Coarsen: after each new keyframe, when the pending bytes need more than max(max_backlog_s, 2 x the keyframe
//   interval) at the current estimate, the older never-attempted keyframes are coarsened, oldest first, until the
//   backlog fits: each is re-reduced once (same frame, same coverage views, the same single call) to
//   coarse_factor x its budget (not below the budget floor) and replaces its outbox entry when smaller.
// The newest keyframe is never coarsened, and the sender posts newest first.
//
// Refinements (on unless refine_ceiling_kb is 0): spare link capacity re-sends an acknowledged keyframe at a larger
// budget as its next revision (Outbox::revise; the server replaces the stored keyframe, one surface per seq). The
// newest keyframe (by capture time) whose budget, or the budget of its last refinement tried, the window's budget
// beats by 1.25 x and 8 kB, from its own frame and pose against the same coverage views as its first revision, at
// the fine settings (FineReduction: its budget is above 40 kB); kept only when the new GLB is at least
// kRefinementKeepRatio (1.25) x the bytes of the revision it replaces: the whole keyframe crosses the line again, and on
// TUM at 2 Mbit/s the refinements of 1.12-1.14 x re-sent keyframes that other runs had got at once at the ceiling,
// for no change in the mission's novel views (13.83-13.84 dB with them, 13.85-13.88 dB without; BENCHMARKS.md stop
// 24). Until stop 24 it was 1.1 x.
// Its budget is what the POST model carries in the window (at most refine_window_s), at most refine_ceiling_kb
// (refinement_budget_kb). The sender posts a first revision before any refinement.
// - While tracking (refine_while_tracking): a refiner thread in the idle scheduling class (SCHED_IDLE: it gets a core
//   only when the tracker and the keyframes' reduction leave one, so it takes neither's time; stop 17 measured what a
//   refinement on the reduction thread cost: the next keyframe's reduction waited, and the latency rule took it out of
//   that keyframe's bytes, 34 -> 18 kB at 2 Mbit/s) refines when no keyframe waits or is being reduced and the sender
//   owes nothing (a refinement's unwritten bytes included). When the sender's refinements yield to keyframes on the
//   line (Sender::refinements_yield: a cap and two lanes or more; rgbdcast stream gives refinements a lane of their
//   own), its window is refine_window_s, as in the drain: a keyframe that comes meanwhile waits for at most a chunk
//   of the refinement's body (or a round trip when every lane is busy), and the line carries the refinement while
//   keyframes' answers are awaited. Otherwise the window ends when the next keyframe's POST is expected (the last
//   keyframe's time + the interval + its reduction, less this refinement's own reduction): a keyframe that comes
//   sooner goes first, with at most the rest of the refinement's body ahead of it on the line. Once tracking is done
//   the thread returns to the normal class (a starved idle-class reduction would hold the drain).
// - In the drain (every frame read): one after another, each reduced once the link owes no more than that takes, so
//   it is ready when the line frees; when no acknowledged keyframe qualifies, one whose POST is out (the link not
//   down) is refined ahead and its revision added once the answer comes. Before any answer has measured the link
//   that is done only under a cap (--link-kbps), at what the cap carries in the window (the estimate never exceeds
//   the cap); when the answer comes, the revision is added at once if the measured link carries its bytes in the
//   window, else it is dropped and the keyframe refined again at the measured budget (counted in
//   refined_ahead_redone). So a single keyframe's stream (ICL) does not idle for its refinement's reduction between
//   the first answer and the refinement's POST. Without a cap, only once some answer has measured the link.
// - Before the first answer, under a cap, when refinements yield (above): the reduction thread refines the keyframe
//   it has just written at once, at the cap's budget (it was sized to the initial estimate), and its revision is
//   added beside the POST still out (Outbox::revise_in_flight: the sender posts it while the first answer is awaited;
//   the server keeps the higher rev whichever arrives first). A keyframe tracked meanwhile waits for that reduction
//   (once per run: only until the first answer). That refinement is reduced beside the keyframe's own reduction, on
//   a thread niced below it, so that it is ready when the keyframe's body has crossed the line (counted in
//   refined_beside_keyframe): made after the keyframe was written, it came 50-60 ms later and the line idled.

// Resume: with entries or deferred records in the outbox, tracking restarts at the latest keyframe's frame, over
// both (the highest frame index: a deferred keyframe reduced already may have a higher seq but an older frame, and a
// deferred record's frame may be the latest), whose pose (from the outbox or the record) anchors the new run's poses
// in the same world; that frame is not tracked as a new keyframe again; sequence numbers continue; the earlier
// keyframes' frames are reloaded as coverage views. Pending entries are posted as usual (a re-post of a stored one is
// answered 200 by the server's idempotency; a pending refinement is posted with its rev). The deferred records'
// frames are re-read from the source and wait as deferred keyframes again: reduced, coarsened, newest first,
// whenever no newer keyframe waits and the link has room, each with the next seq and against every entry before it,
// as they would have been. Each is then a new outbox entry, whose record goes in the same Outbox::add, so none is
// reduced or sent twice (Outbox::open removes a record whose frame already has an entry, for a crash between the
// two). So a stop loses nothing that was tracked as a keyframe: the keyframes still queued or held for the link lie
// after the resume point and are tracked again, and the deferred ones are in their records. What a run can still
// lose is documented: the max_deferred rule's drops (counted), and a deferred keyframe whose record could not be
// written (reported in `errors`).
#include <functional>
#include <string>

#include "input/frame_source.h"
#include "keyframes/sequence.h"
#include "pipeline/frame_scene.h"
#include "stream/link_estimator.h"
#include "stream/outbox.h"
#include "stream/sender.h"

namespace rgbdcast::stream {

// Fidelity for large budgets. The realtime reduction's defaults saturate on a delta keyframe well under 100 kB
// (tolerance at its floor of 2 sigma, JPEG at its budget's best quality 92, collapses at 2 px: at a 100 kB budget the
// scene "fits" with bytes to spare; BENCHMARKS.md stop 17), so the bytes a fast link has room for could buy nothing.
// A keyframe or refinement whose budget is above `above_kb` is reduced with these settings instead; the budget still
// raises the tolerance and lowers the quality as it needs. By default only the JPEG ceiling moves (92 -> 98): at a
// 300 kB budget on TUM fr1/xyz 200-319 frame 60 and augmented ICL frame 0 (whole frames), q98 against q92 gave
// +1.24 / +1.20 dB over the pixels drawn at the capture pose and +0.51 / +0.17 dB over all valid pixels, the same
// coverage and novel views, for 1.68 / 1.42 x the bytes. A finer tolerance or finer collapses changed which border
// pixels are covered more than the surface (all-valid PSNR -2.4 to +0.4 dB), so they stay at the defaults unless
// asked for (BENCHMARKS.md stop 20).
struct FineReduction {
  double above_kb = 40;       // --fine-above-kb: budgets above this use the settings below (0: never)
  double tolerance = 2.0;     // --fine-tolerance: the tolerance floor, sigma (never above the default reduction's)
  double simplify_px = 2.0;   // --fine-simplify-px: the collapses' limit (0: off; never above the default's)
  int max_jpeg_quality = 98;  // --fine-max-quality: the budget's best JPEG quality (never below the default's 92)
};

// `base` for a keyframe or refinement of budget_kb: above fine.above_kb (when that is > 0), its tolerance floor and
// collapses at most fine's, its best JPEG quality at least fine's; otherwise `base` as it is.
FrameReductionOptions reduction_for_budget(const FrameReductionOptions& base, const FineReduction& fine,
                                           double budget_kb);

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
  int reduce_nice = 5;              // --reduce-nice: added to the reduction thread's niceness (0: as the caller)
  bool supersede = true;            // the backlog rule's first step; --keep-every-keyframe turns it off
  size_t max_deferred = 16;         // deferred keyframes waiting at most (beyond: the oldest is dropped)
  double refine_ceiling_kb = 200;   // --refine-kb: a refinement's largest budget (0: no refinements)
  double refine_window_s = 1.0;     // --refine-window-ms: a refinement's longest time on the line
  // --no-refine-while-tracking turns off: refinements between keyframes while tracking, on their own thread at the
  // idle scheduling class (see above).
  bool refine_while_tracking = true;
  FineReduction fine;
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

// A refinement replaces its keyframe only when its GLB has at least this many times the bytes (see above).
inline constexpr double kRefinementKeepRatio = 1.25;

struct StreamSummary {
  size_t frames = 0, tracked = 0, dropped = 0;  // dropped: stale frames skipped in realtime
  size_t keyframes = 0;       // new outbox entries of this run
  size_t covered = 0;         // keyframes with nothing new (not sent)
  size_t coarsened = 0;
  size_t superseded = 0;      // tracked keyframes deferred: a newer one went first while the link owed too much
  size_t deferred_sent = 0;   // of which reduced later (coarsened) and written to the outbox
  size_t deferred_dropped = 0;  // deferred keyframes dropped (more than max_deferred waited; resumed ones included)
  size_t refined = 0;         // refinements written to the outbox (revisions)
  size_t refined_while_tracking = 0;  // of which made between keyframes, before every frame was read
  size_t refined_ahead = 0;   // of which reduced while their keyframe's POST was out (added once it was answered)
  size_t refined_ahead_redone = 0;  // sized to the cap before any answer, too large for the measured link: made again
  size_t refined_beside_keyframe = 0;  // of the refinements added, reduced beside their keyframe's own reduction
  size_t refined_not_kept = 0;  // refinements reduced but not added: under kRefinementKeepRatio x the bytes
  size_t refine_saturated = 0;  // keyframe revisions not refined: they "fit", so a larger budget gives them again
  size_t cap_changes = 0;     // values taken from --link-kbps-file
  size_t failed = 0;          // keyframes whose reduction or outbox write failed (message in errors)
  bool resumed = false;
  int resumed_at_frame = -1;
  size_t resumed_entries = 0;
  size_t resumed_deferred = 0;       // deferred keyframes reloaded from the outbox's records
  size_t resumed_deferred_sent = 0;  // of which reduced (coarsened) and written to the outbox by this run
  size_t deferred_waiting = 0;       // deferred keyframes still waiting in the outbox's records at the end (a stop)
  double seconds = 0;
  bool stopped = false;       // stop was asked before everything was delivered
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
