// rgbdcast stream: a live mission. Tracks a frame source, reduces each keyframe to a delta GLB under a byte budget
// that follows the link, and delivers it to `rgbdcast serve`'s missions routes through an on-disk outbox (see
// stream/keyframe_stream.h for the rules, stream/sender.h for delivery). SIGINT/SIGTERM stop it: what was not
// delivered stays in the outbox, and running the same command again resumes.
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <regex>

#include "app/cli_error.h"
#include "app/commands.h"
#include "app/reduce_common.h"
#include "base/atomic_file.h"
#include "base/malloc_settings.h"
#include "input/frame_source.h"
#include "stream/keyframe_stream.h"
#include "stream/uplink.h"

namespace rgbdcast::app {

namespace {

std::atomic<bool> g_stop{false};  // set by SIGINT/SIGTERM only
void on_signal(int) { g_stop = true; }

struct StreamArgs {
  ReduceArgs reduce;  // input, intrinsics, features, keyframe rule, range
  std::string server, mission, outbox, token_file, link_kbps_file, post_log;
  bool realtime = false;
  double link_kbps = 0, initial_kbps = 500, latency_ms = 1000, max_backlog_s = 2.0, progress_interval_s = 2.0;
  double refine_kb = 200, refine_window_ms = 1000;
  double max_keyframe_kb = 100;
  bool no_refine_while_tracking = false;
  stream::FineReduction fine;
  unsigned seed = 0;
  int max_in_flight = 2;
  int reduce_nice = 5;
  bool keep_every_keyframe = false;
};

// The progress line: on a terminal one line redrawn in place; otherwise a plain line every interval.
class ProgressLine {
 public:
  explicit ProgressLine(double interval_s) : tty_(::isatty(STDERR_FILENO)), interval_s_(interval_s) {}
  void update(const stream::StreamProgress& p, bool force = false) {
    const auto now = std::chrono::steady_clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    if (!force && since < (tty_ ? 0.2 : interval_s_)) return;
    last_ = now;
    char line[320];
    std::snprintf(line, sizeof line,
                  "frames %zu/%zu  keyframes %zu (budget %.1f kB)  sent %zu, %.1f kB  link %.0f kbit/s%s%s  queue %zu "
                  "(%.1f kB)%s",
                  p.frames_done, p.frames_total, p.keyframes, p.budget_kb, p.sender.acked,
                  p.sender.acked_bytes / 1000.0, p.sender.estimate_kbps, p.sender.link_down ? " (down)" : "",
                  p.sender.cap_kbps > 0 ? (" cap " + std::to_string(static_cast<int>(p.sender.cap_kbps))).c_str() : "",
                  p.sender.pending, p.sender.pending_bytes / 1000.0, p.draining ? "  draining" : "");
    if (tty_) {
      std::fprintf(stderr, "\r%-118s", line);
    } else {
      std::fprintf(stderr, "rgbdcast stream: %s\n", line);
    }
    std::fflush(stderr);
    drawn_ = true;
  }
  void finish() {
    if (tty_ && drawn_) std::fprintf(stderr, "\n");
  }

 private:
  bool tty_;
  double interval_s_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point last_{};
};

void run_stream_command(const StreamArgs& a, const RosbagTopics& topics) {
  apply_malloc_settings(frame_loop_malloc_settings());
  auto fail_stream = [](const Error& e) { fail("stream", e); };
  static const std::regex mission_name("^[A-Za-z0-9_-]{1,64}$");
  if (!std::regex_match(a.mission, mission_name))
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--mission must match [A-Za-z0-9_-]{1,64}"));
  stream::LinkEstimatorParams link;
  link.cap_kbps = a.link_kbps;
  link.initial_kbps = a.initial_kbps;
  if (auto st = link.validate(); !st) fail_stream(st.error());
  if (!std::isfinite(a.latency_ms) || a.latency_ms < 0)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--latency-ms must be a finite number >= 0 (0: off)"));

  stream::UplinkOptions uo;
  uo.server_url = a.server;
  if (!a.token_file.empty()) {
    auto token = stream::read_token_file(a.token_file);
    if (!token) fail_stream(token.error());
    uo.token = *token;
  }
  if (a.max_in_flight < 1 || a.max_in_flight > 4)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--max-in-flight must be 1..4"));
  if (!std::isfinite(a.refine_kb) || a.refine_kb < 0 || a.refine_kb > 1000)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--refine-kb must be 0..1000 (0: no refinements)"));
  if (!std::isfinite(a.refine_window_ms) || a.refine_window_ms <= 0 || a.refine_window_ms > 60000)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--refine-window-ms must be in (0, 60000]"));
  if (!std::isfinite(a.max_keyframe_kb) || a.max_keyframe_kb < 4 || a.max_keyframe_kb > 1000)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--max-keyframe-kb must be 4..1000"));
  if (!std::isfinite(a.fine.above_kb) || a.fine.above_kb < 0)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--fine-above-kb must be >= 0 (0: never)"));
  if (!std::isfinite(a.fine.tolerance) || a.fine.tolerance <= 0)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--fine-tolerance must be > 0"));
  if (!std::isfinite(a.fine.simplify_px) || a.fine.simplify_px < 0)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--fine-simplify-px must be >= 0 (0: off)"));
  if (a.fine.max_jpeg_quality < 20 || a.fine.max_jpeg_quality > 100)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--fine-max-quality must be 20..100"));
  if (a.reduce_nice < 0 || a.reduce_nice > 19)
    fail_stream(make_error(ErrorCode::kInvalidArgument, "--reduce-nice must be 0..19"));
  // One uplink (one keep-alive connection) per lane of the sender.
  std::vector<std::unique_ptr<stream::Uplink>> uplinks;
  // Refinements get a connection more (stream/sender.h): one being written never takes a keyframe's lane.
  const int connections = a.max_in_flight + (a.refine_kb > 0 && a.max_in_flight >= 2 ? 1 : 0);
  for (int i = 0; i < connections; ++i) {
    auto u = stream::Uplink::create(uo);
    if (!u) fail_stream(u.error());
    uplinks.push_back(std::move(*u));
  }
  stream::Uplink* const uplink = uplinks.front().get();

  ReduceArgs r = a.reduce;
  r.preset = "realtime";
  r.budget_kb = kDefaultBudgetKb;
  auto reduction = frame_options(r);
  if (!reduction) fail_stream(reduction.error());
  auto sequence = sequence_params(r);
  if (!sequence) fail_stream(sequence.error());

  auto so = source_options(r, topics);
  if (!so) fail_stream(so.error());
  auto source = open_frame_source(r.input, *so);
  if (!source) fail_stream(source.error());

  if (auto st = uplink->check_reachable(); !st) fail_stream(st.error());
  // The POST model's first fixed cost: a bodiless request's round trip on the connection just opened (so the first
  // keyframe's answer already gives a line rate; BENCHMARKS.md, "Live missions over an emulated link"). Not fatal: 0
  // without it.
  if (auto rtt = uplink->round_trip_s()) link.initial_fixed_s = *rtt;
  const std::string outbox_dir = a.outbox.empty() ? "rgbdcast-outbox-" + a.mission : a.outbox;
  auto outbox = stream::Outbox::open(outbox_dir, a.mission);
  if (!outbox) fail_stream(outbox.error());

  stream::SenderParams sp;
  sp.mission = a.mission;
  sp.link = link;
  sp.seed = a.seed;
  sp.max_first_in_flight = static_cast<size_t>(a.max_in_flight);
  std::vector<stream::Uplink*> lanes;
  for (auto& u : uplinks) lanes.push_back(u.get());
  stream::Sender sender(**outbox, lanes, sp);

  stream::StreamOptions options;
  options.realtime = a.realtime;
  options.reduction = *reduction;
  options.sequence = *sequence;
  options.max_backlog_s = a.max_backlog_s;
  options.latency.target_s = a.latency_ms / 1000.0;
  options.link_kbps_file = a.link_kbps_file;
  options.reduce_nice = a.reduce_nice;
  options.supersede = !a.keep_every_keyframe;
  options.refine_ceiling_kb = a.refine_kb;
  options.refine_window_s = a.refine_window_ms / 1000.0;
  options.refine_while_tracking = !a.no_refine_while_tracking;
  options.budget.ceiling_kb = a.max_keyframe_kb;
  options.fine = a.fine;

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  // httplib's client writes without MSG_NOSIGNAL: a server that answers and closes while a body is still being
  // written (a 408 after an outage) would kill the stream with SIGPIPE; ignored, the write fails and is retried.
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigaction(SIGPIPE, &ignore, nullptr);
  ProgressLine line(a.progress_interval_s);
  auto summary = stream::run_stream(
      **source, **outbox, sender, options, [&](const stream::StreamProgress& p) { line.update(p); },
      [] { return g_stop.load(); });
  line.finish();
  if (!a.post_log.empty()) {  // one JSON line per POST of this run: {"seq","rev","bytes","started","ended","stored"}
    std::string text;
    char row[200];
    for (const stream::PostRecord& p : sender.post_log()) {
      std::snprintf(row, sizeof row,
                    "{\"seq\": %d, \"rev\": %d, \"bytes\": %zu, \"started\": %.6f, \"ended\": %.6f, \"stored\": %s}\n",
                    p.seq, p.rev, p.bytes, p.started, p.ended, p.stored ? "true" : "false");
      text += row;
    }
    if (Status st = write_file_atomically(a.post_log, std::vector<std::uint8_t>(text.begin(), text.end())); !st)
      std::cerr << "rgbdcast stream: --post-log: " << st.error().message << "\n";
  }
  if (!summary) fail_stream(summary.error());
  const auto& s = *summary;
  std::cout << "rgbdcast stream: " << s.frames << " frames (" << s.tracked << " tracked";
  if (a.realtime) std::cout << ", " << s.dropped << " dropped behind the camera";
  std::cout << "), " << s.keyframes << " new keyframes (" << s.covered << " fully covered, not sent; " << s.coarsened
            << " coarsened, " << s.superseded << " deferred while the link owed too much: " << s.deferred_sent
            << " of them sent later, coarsened, " << s.deferred_dropped << " dropped; " << s.refined_while_tracking
            << " made while tracking, " << s.refined_ahead << " reduced before their keyframe's answer ("
            << s.refined_ahead_redone << " made again for the measured link; " << s.refined_beside_keyframe
            << " beside the keyframe's own reduction; " << s.refined_not_kept << " reduced and not kept, under "
            << stream::kRefinementKeepRatio << " x the bytes; " << s.refine_saturated
            << " not tried, their GLB already the finest their settings make) of " << s.refined << " refinements)";
  if (s.cap_changes > 0) std::cout << ", " << s.cap_changes << " caps read from " << a.link_kbps_file;
  if (s.resumed)
    std::cout << ", resumed at frame " << s.resumed_at_frame << " after " << s.resumed_entries << " outbox entries and "
              << s.resumed_deferred << " deferred keyframes (" << s.resumed_deferred_sent
              << " of them sent, coarsened)";
  std::cout << "; " << s.sender.acked << " acknowledged (" << s.sender.acked_bytes / 1000.0 << " kB this run, "
            << s.sender.posts << " posts, " << s.sender.failures << " failed, busy " << s.sender.busy_s << " s, "
            << s.sender.overlap_s << " s of it with 2+ in flight; refinements " << s.sender.refinements_acked << ", "
            << s.sender.refinement_bytes / 1000.0 << " kB), " << s.sender.pending << " pending, " << s.sender.rejected
            << " rejected; link " << static_cast<int>(s.sender.estimate_kbps) << " kbit/s (POST model: line "
            << static_cast<int>(s.sender.line_kbps) << " kbit/s + " << static_cast<int>(1000 * s.sender.post_fixed_s)
            << " ms per POST); " << static_cast<int>(s.seconds * 1000) << " ms; outbox " << outbox_dir << "\n";
  {
    // The live figures: is the tracker keeping up with the camera, and what a keyframe's reduction costs.
    const auto fw = stream::percentiles(s.frame_wall_ms), fc = stream::percentiles(s.frame_cpu_ms);
    const auto fr = stream::percentiles(s.read_cpu_ms), rw = stream::percentiles(s.reduce_ms);
    std::printf(
        "  tracking: %zu frames read, %zu tracked, %zu dropped; per frame read: due -> tracked wall p50 %.1f / "
        "p95 %.1f ms, reader CPU p50 %.1f / p95 %.1f ms, tracker CPU p50 %.1f / p95 %.1f ms; keyframe "
        "reduction (%zu, own thread at nice +%d): wall p50 %.0f / p95 %.0f ms, queue max %zu\n",
        s.frames - s.dropped, s.tracked, s.dropped, fw.p50, fw.p95, fr.p50, fr.p95, fc.p50, fc.p95, s.reduce_ms.size(),
        a.reduce_nice, rw.p50, rw.p95, s.reduce_queue_max);
    std::fflush(stdout);
  }
  for (const auto& e : s.errors) std::cout << "  " << e << "\n";
  if (s.sender.rejected > 0)
    fail("stream", make_error(ErrorCode::kInternal,
                              std::to_string(s.sender.rejected) +
                                  " keyframes were rejected by the server (last: " + s.sender.last_error + ")"));
  if (s.sender.pending > 0 || s.deferred_waiting > 0) {
    std::string waiting = std::to_string(s.sender.pending) + " keyframes are still in the outbox " + outbox_dir;
    if (s.deferred_waiting > 0)
      waiting += " and " + std::to_string(s.deferred_waiting) + " deferred ones wait there to be reduced";
    fail("stream", make_error(ErrorCode::kUnavailable, waiting + " (run the same command again to send them)"));
  }
}

}  // namespace

void register_stream(CLI::App& app) {
  auto args = std::make_shared<StreamArgs>();
  auto topics = std::make_shared<RosbagTopics>();
  CLI::App* cmd = app.add_subcommand("stream", "Stream a live mission: keyframes to a server, within the link");
  ReduceArgs& r = args->reduce;
  cmd->add_option("--input", r.input, "Frame source: TUM folder, Redwood/ICL folder, .bag")->required();
  cmd->add_option("--server", args->server, "The service, http://host:port")->required();
  cmd->add_option("--mission", args->mission, "Mission name ([A-Za-z0-9_-]{1,64})")->required();
  cmd->add_flag("--realtime", args->realtime,
                "Read frames at their own timestamps (dropping those a newer frame has replaced)");
  cmd->add_option("--link-kbps", args->link_kbps, "Cap of the link estimate and of the send rate, kbit/s (0: none)")
      ->capture_default_str();
  cmd->add_option("--link-kbps-file", args->link_kbps_file,
                  "Control file holding the cap in kbit/s (one number, 0: none), re-read on every frame: write a "
                  "new number to change the cap while streaming; it overrides --link-kbps once it holds one");
  cmd->add_option("--latency-ms", args->latency_ms,
                  "Capture-to-view target: each keyframe's budget is also kept to what the link estimate carries "
                  "in this time minus the measured time before its POST (0: off)")
      ->capture_default_str();
  cmd->add_option("--initial-kbps", args->initial_kbps, "Link estimate before the first acknowledgement")
      ->capture_default_str();
  cmd->add_option("--outbox", args->outbox, "Outbox folder (default: ./rgbdcast-outbox-<mission>)");
  cmd->add_option("--token-file", args->token_file, "File holding the server's bearer token");
  cmd->add_option("--max-backlog", args->max_backlog_s,
                  "Coarsen older queued keyframes when the queue needs more than this many seconds (at least 2 "
                  "keyframe intervals)")
      ->capture_default_str();
  cmd->add_option("--progress-interval", args->progress_interval_s,
                  "Seconds between progress lines when stderr is not a terminal")
      ->capture_default_str();
  cmd->add_option("--seed", args->seed, "Seed of the retry jitter (0: random)");
  cmd->add_option("--max-in-flight", args->max_in_flight,
                  "Keyframes' POSTs in flight at once, one connection each (1-4): a second one crosses the line "
                  "while the first one's answer is outstanding (with 2 or more, refinements get one connection more)")
      ->capture_default_str();
  cmd->add_flag("--keep-every-keyframe", args->keep_every_keyframe,
                "Reduce and send every keyframe in order, even when the link cannot carry them (default: a "
                "keyframe waiting for a busy link lets a newer one go first, and follows it coarsened)");
  cmd->add_option("--refine-kb", args->refine_kb,
                  "Largest budget of a refinement: an idle link re-sends an acknowledged keyframe at a larger "
                  "budget as its next revision, which replaces it on the server (0: no refinements)")
      ->capture_default_str();
  cmd->add_option("--refine-window-ms", args->refine_window_ms,
                  "Longest time a refinement may hold the line (a new keyframe waits at most that long)")
      ->capture_default_str();
  cmd->add_flag("--no-refine-while-tracking", args->no_refine_while_tracking,
                "Refine only once every frame was read (default: also between keyframes, on an idle-class thread, "
                "sized to end before the next keyframe is expected)");
  cmd->add_option("--max-keyframe-kb", args->max_keyframe_kb,
                  "Largest budget of a keyframe's first revision (the rate and latency rules give less on a slower "
                  "link)")
      ->capture_default_str();
  cmd->add_option("--fine-above-kb", args->fine.above_kb,
                  "Budgets above this are reduced with the --fine-* settings, so that more bytes buy a better "
                  "keyframe (0: never)")
      ->capture_default_str();
  cmd->add_option("--fine-tolerance", args->fine.tolerance, "Tolerance floor of a fine reduction (sigma)")
      ->capture_default_str();
  cmd->add_option("--fine-simplify-px", args->fine.simplify_px, "Collapses' limit of a fine reduction (pixels; 0: off)")
      ->capture_default_str();
  cmd->add_option("--fine-max-quality", args->fine.max_jpeg_quality, "Best JPEG quality of a fine reduction")
      ->capture_default_str();
  cmd->add_option("--post-log", args->post_log,
                  "Write every POST of this run (seq, rev, bytes, start and answer times) to this file, one JSON line "
                  "each");
  cmd->add_option("--reduce-nice", args->reduce_nice,
                  "Niceness added to the keyframe reduction thread (0-19), so that tracking keeps up with the camera")
      ->capture_default_str();
  cmd->add_option("--intrinsics", r.intrinsics,
                  "fr1|fr2|fr3|kinect|icl, a JSON file or a 3x3 matrix .txt file (default: guessed)");
  cmd->add_option("--depth-scale", r.depth_scale, "Raw depth units per metre");
  cmd->add_option("--associations", r.associations, "TUM associations file");
  cmd->add_option("--depth-encoding", r.depth_encoding, "png16, nyu (Kinect disparity PGM) or sun (bit-rotated mm)")
      ->capture_default_str();
  cmd->add_option("--color-topic", topics->color, "ROS bag: colour topic")->capture_default_str();
  cmd->add_option("--depth-topic", topics->depth, "ROS bag: depth topic")->capture_default_str();
  cmd->add_option("--camera-info-topic", topics->camera_info, "ROS bag: camera info topic")->capture_default_str();
  cmd->add_option("--from", r.from, "First frame index");
  cmd->add_option("--to", r.to, "Last frame index (inclusive)");
  // Live defaults: ORB features and the live tracking setting keep up with the camera (BENCHMARKS.md, "Tracking
  // through real motion"); reduce --sequence keeps SIFT and robust.
  r.features = "orb";
  r.tracking = "live";
  cmd->add_option("--features", r.features, "sift|orb|akaze")->capture_default_str();
  cmd->add_option("--tracking", r.tracking, "robust | paper (the window alone) | live (the fast setting of robust)")
      ->capture_default_str();
  cmd->add_option("--keyframe-translation", r.keyframe_translation_m, "New keyframe after this much translation (m)")
      ->capture_default_str();
  cmd->add_option("--keyframe-rotation", r.keyframe_rotation_deg, "... or this much rotation (deg)")
      ->capture_default_str();
  cmd->add_option("--keyframe-overlap", r.keyframe_overlap, "... or when overlap falls below this")
      ->capture_default_str();
  cmd->add_option("--keyframe-gap", r.keyframe_gap, "... or after this many frames (0 = never)")->capture_default_str();
  cmd->callback([args, topics] { run_stream_command(*args, *topics); });
}

}  // namespace rgbdcast::app
