// rgbdcast stream end to end against the real `rgbdcast serve`, on the first 41 real frames of TUM fr1/xyz 200-319:
// - the budget follows --link-kbps (2000 vs 100 kbit/s: smaller keyframes, the acknowledged rate under the cap);
// - a sender killed (SIGKILL) mid-mission and started again: nothing lost, nothing duplicated, the same keyframes
//   as the uninterrupted run;
// - a sender killed (and then stopped) while keyframes wait deferred, and started again: each deferred keyframe
//   reaches the mission once;
// - the budget follows a --link-kbps changed while streaming (--link-kbps-file);
// - bad input gets a one-line error.
#include <gtest/gtest.h>
#include <httplib.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "tests/common/run_command.h"
#include "tests/common/test_data.h"
#include "tests/service/server_process.h"

extern char** environ;

namespace rgbdcast::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const char* kSequence = "tum/rgbd_dataset_freiburg1_xyz_200_319";

// The outbox's JSON files named `<prefix>...json`, in name order: "kf-" the entries (by seq), "deferred-" the
// deferred keyframes' records (by frame).
std::vector<json> outbox_files(const std::string& dir, const std::string& prefix) {
  std::vector<std::string> names;
  for (const auto& f : fs::directory_iterator(dir))
    if (f.path().filename().string().rfind(prefix, 0) == 0 && f.path().extension() == ".json")
      names.push_back(f.path().string());
  std::sort(names.begin(), names.end());
  std::vector<json> out;
  for (const auto& n : names) out.push_back(json::parse(read_file(n)));
  return out;
}
std::vector<json> outbox_entries(const std::string& dir) { return outbox_files(dir, "kf-"); }

// Starts `cmd` (stdout and stderr to `log`) and sends it `signal` as soon as `ready()` holds, then waits for it.
// `signalled`: whether it was sent so (false: it ended first, or `timeout_s` passed and it was killed);
// `exit_code`: its exit code when it exited (-1 when a signal ended it).
struct Stopped {
  bool signalled = false;
  int exit_code = -1;
};
Stopped stop_when(const std::string& cmd, const std::function<bool()>& ready, int timeout_s, int signal = SIGKILL,
                  const std::string& log = "/dev/null") {
  Stopped out;
  pid_t pid = -1;
  const std::string exec_cmd = "exec " + cmd + " >" + log + " 2>&1";
  const char* argv[] = {"/bin/sh", "-c", exec_cmd.c_str(), nullptr};
  if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) return out;
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  for (;;) {
    if (waitpid(pid, &status, WNOHANG) == pid) break;
    const bool late = std::chrono::steady_clock::now() >= deadline;
    if (late || ready()) {
      out.signalled = !late;
      ::kill(pid, late ? SIGKILL : signal);
      waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (WIFEXITED(status)) out.exit_code = WEXITSTATUS(status);
  return out;
}

json mission(int port, const std::string& name) {
  httplib::Client c("127.0.0.1", port);
  auto res = c.Get(("/v1/missions/" + name).c_str());
  if (!res || res->status != 200) return json();
  return json::parse(res->body);
}

std::string stream_command(int port, const std::string& mission_name, const std::string& outbox, double kbps,
                           const std::string& extra = "") {
  return rgbdcast_binary() + " stream --input " + data_path(kSequence) +
         " --to 40 --server http://127.0.0.1:" + std::to_string(port) + " --mission " + mission_name + " --outbox " +
         outbox + " --link-kbps " + std::to_string(kbps) + " --seed 5 " + extra;
}

// "N <what>" from the summary line (e.g. " deferred while", " fully covered", " refinements)"); -1 when absent.
int count_before(const std::string& out, const std::string& what) {
  const auto at = out.find(what);
  if (at == std::string::npos) return -1;
  size_t start = at;
  while (start > 0 && std::isdigit(static_cast<unsigned char>(out[start - 1]))) --start;
  if (start == at) return -1;
  return std::stoi(out.substr(start, at - start));
}

struct MissionRun {
  std::vector<json> outbox;
  json mission;
  double bytes_per_keyframe = 0;
};

MissionRun summarize(int port, const std::string& name, const std::string& outbox) {
  MissionRun r;
  r.outbox = outbox_entries(outbox);
  r.mission = mission(port, name);
  double bytes = 0;
  for (const auto& e : r.outbox) bytes += e["bytes"].get<double>();
  if (!r.outbox.empty()) r.bytes_per_keyframe = bytes / r.outbox.size();
  return r;
}

// Nothing lost, nothing duplicated: the mission holds exactly the outbox's keyframes, each once, same bytes.
void expect_mission_matches_outbox(const MissionRun& r) {
  ASSERT_TRUE(r.mission.is_object());
  std::map<int, size_t> on_server;
  for (const auto& k : r.mission["keyframes"]) {
    const int seq = k["seq"].get<int>();
    EXPECT_FALSE(on_server.count(seq)) << "seq " << seq << " twice on the server";
    on_server[seq] = k["bytes"].get<size_t>();
  }
  EXPECT_EQ(on_server.size(), r.outbox.size());
  std::set<int> frames;
  for (const auto& e : r.outbox) {
    EXPECT_TRUE(e["acked"].get<bool>()) << e.dump();
    const int seq = e["seq"].get<int>();
    ASSERT_TRUE(on_server.count(seq)) << "seq " << seq << " lost";
    EXPECT_EQ(on_server[seq], e["bytes"].get<size_t>());
    EXPECT_TRUE(frames.insert(e["frame"].get<int>()).second) << "frame " << e["frame"].dump() << " sent twice";
  }
}

std::vector<int> keyframe_frames(const MissionRun& r) {
  std::vector<int> f;
  for (const auto& e : r.outbox) f.push_back(e["frame"].get<int>());
  std::sort(f.begin(), f.end());
  return f;
}

class StreamCli : public ::testing::Test {
 protected:
  void SetUp() override {
    REQUIRE_DATA(kSequence);
    dir_ = temp_dir("stream_cli");
    std::string error;
    ASSERT_TRUE(server_.start(dir_ + "/data", {}, &error)) << error;
  }
  void TearDown() override {
    server_.stop();
    if (!dir_.empty()) remove_tree_quietly(dir_);
  }
  std::string dir_;
  ServerProcess server_;
};

TEST_F(StreamCli, BudgetFollowsLinkKbpsAndARestartedSenderLosesAndDuplicatesNothing) {
  // Uninterrupted at 2 Mbit/s.
  const std::string fast_box = dir_ + "/fast";
  auto fast_cmd = run_command(stream_command(server_.port(), "fast", fast_box, 2000));
  ASSERT_EQ(fast_cmd.exit_code, 0) << fast_cmd.out << fast_cmd.err;
  const MissionRun fast = summarize(server_.port(), "fast", fast_box);
  ASSERT_GE(fast.outbox.size(), 2u);
  expect_mission_matches_outbox(fast);

  // At 20 kbit/s the link, not the tracking, is the bottleneck: the budgets follow it down; the keyframes do not
  // grow, but they do not reach the budget either (the realtime reduction bottoms out near 32-47 kB on these frames
  // within its limits of 32 sigma and a half-size texture: BENCHMARKS.md "Live missions"); the sender's pacing keeps
  // the acknowledged rate under the cap. (On 2 busy cores keyframes come every few seconds; the budget rule clamps the
  // interval to 5 s, so 20 kbit/s allows at most 2.5 kB/s x 5 s x 0.9 = 11.25 kB per keyframe.)
  const std::string slow_box = dir_ + "/slow";
  auto slow_cmd = run_command(stream_command(server_.port(), "slow", slow_box, 20));
  ASSERT_EQ(slow_cmd.exit_code, 0) << slow_cmd.out << slow_cmd.err;
  const MissionRun slow = summarize(server_.port(), "slow", slow_box);
  expect_mission_matches_outbox(slow);
  // The link changes the bytes and the order, not which of the tracker's keyframes reach the mission: while the
  // sender owes the link more than a reduction takes, a waiting keyframe lets a newer one go first and follows it,
  // coarsened. The tracking is the same, so the slow run sends the fast run's keyframes, less only those a later one
  // covered entirely (a deferred keyframe is reduced against the newer one).
  const std::vector<int> fast_frames = keyframe_frames(fast), slow_frames = keyframe_frames(slow);
  EXPECT_TRUE(std::includes(fast_frames.begin(), fast_frames.end(), slow_frames.begin(), slow_frames.end()));
  ASSERT_FALSE(slow_frames.empty());
  EXPECT_EQ(slow_frames.back(), fast_frames.back());
  EXPECT_EQ(count_before(fast_cmd.out, " deferred while"), 0) << fast_cmd.out;
  const int covered_fast = count_before(fast_cmd.out, " fully covered"),
            covered_slow = count_before(slow_cmd.out, " fully covered");
  ASSERT_GE(covered_slow, 0) << slow_cmd.out;
  EXPECT_EQ(slow_frames.size() + static_cast<size_t>(covered_slow), fast_frames.size() + covered_fast) << slow_cmd.out;
  EXPECT_EQ(count_before(slow_cmd.out, " of them sent later"), count_before(slow_cmd.out, " deferred while"))
      << slow_cmd.out;
  // (Whether any is deferred depends on how fast this machine tracks against 3+ s of line per keyframe at 20 kbit/s:
  // on a quiet one it was 1 of 3; at load 12, 0. The accounting above holds either way.)
  // At 2 Mbit/s the idle link refined keyframes (revisions that replaced them on the server: still one per seq,
  // with the outbox's bytes, checked above; a keyframe refined twice is at rev 2); at 20 kbit/s a second of line buys
  // too little to refine.
  EXPECT_GE(count_before(fast_cmd.out, " refinements)"), 1) << fast_cmd.out;
  EXPECT_EQ(count_before(slow_cmd.out, " refinements)"), 0) << slow_cmd.out;
  size_t revised = 0;
  for (const auto& k : fast.mission["keyframes"]) revised += static_cast<size_t>(k.value("rev", 0));  // one a rev
  EXPECT_EQ(static_cast<int>(revised), count_before(fast_cmd.out, " refinements)")) << fast.mission.dump();
  EXPECT_LE(slow.bytes_per_keyframe, 1.02 * fast.bytes_per_keyframe)
      << slow.bytes_per_keyframe << " vs " << fast.bytes_per_keyframe;
  for (const auto& e : fast.outbox) EXPECT_GT(e["budget_kb"].get<double>(), 11.25 + 1e-9) << e.dump();
  for (const auto& e : slow.outbox) EXPECT_LE(e["budget_kb"].get<double>(), 11.25 + 1e-9) << e.dump();
  // Paced: every keyframe but the last arrived no faster than the cap allows. The server stamps `received` when a
  // POST's headers arrive, so the span of the stamps can fall short of the sender's by the difference between the
  // first POST's delay and the last one's (the first opens the connection and creates the mission, and on 2 busy
  // cores a server thread may wait its turn). A second of it is allowed: unpaced, these keyframes (about 7 s of line
  // at the cap) would all arrive within it. The pacing itself is checked on an injected clock
  // (SenderLanes.PacingAtTheCapWaitsOnTheInjectedClock).
  constexpr double kStampJitterS = 1.0;
  std::vector<std::pair<double, double>> arrivals;  // received, bytes
  for (const auto& k : slow.mission["keyframes"])
    arrivals.push_back({k["received"].get<double>(), k["bytes"].get<double>()});
  std::sort(arrivals.begin(), arrivals.end());
  double paced_bytes = 0;
  for (size_t i = 0; i + 1 < arrivals.size(); ++i) paced_bytes += arrivals[i].second;
  const double span_s = arrivals.back().first - arrivals.front().first;
  EXPECT_LE(paced_bytes * 8 / 1000, 20 * (span_s + kStampJitterS)) << paced_bytes << " bytes in " << span_s << " s";

  // Killed mid-mission once a keyframe was acknowledged, then started again with the same outbox. (With
  // --keep-every-keyframe nothing is superseded, so the resumed mission must hold exactly the fast run's keyframes.)
  const std::string box = dir_ + "/restart";
  const std::string cmd = stream_command(server_.port(), "restart", box, 300, "--keep-every-keyframe");
  const bool killed_mid_mission =
      stop_when(
          cmd,
          [&] {
            if (!fs::exists(box)) return false;
            const auto entries = outbox_entries(box);
            return std::any_of(entries.begin(), entries.end(), [](const json& e) { return e["acked"].get<bool>(); });
          },
          240)
          .signalled;
  ASSERT_TRUE(killed_mid_mission) << "the sender finished before a keyframe was acknowledged";
  const size_t before = outbox_entries(box).size();
  EXPECT_LT(before, fast.outbox.size()) << "killed too late to test a resume";
  auto again = run_command(cmd);
  ASSERT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_NE(again.out.find("resumed at frame"), std::string::npos) << again.out;
  const MissionRun resumed = summarize(server_.port(), "restart", box);
  expect_mission_matches_outbox(resumed);
  EXPECT_EQ(keyframe_frames(resumed), fast_frames);
  // seq numbering continued: 0..n-1, no gap.
  for (size_t i = 0; i < resumed.outbox.size(); ++i) EXPECT_EQ(resumed.outbox[i]["seq"].get<size_t>(), i);
}

// A sender killed while keyframes wait deferred (the backlog rule let newer ones go first), then started again:
// their records are in the outbox's folder. Restarted on the same slow link and stopped (SIGINT) while they still
// wait, it says so and exits 1; restarted on a fast link, it reduces each one and delivers it: every deferred
// keyframe reaches the mission exactly once, coarsened, after the keyframes before it, with seqs unique and
// contiguous; no record is left.
// Refinements between keyframes while tracking: frames read at their own timestamps (41 frames, 1.4 s) and keyframes
// 15 cm apart leave the 2 Mbit/s line idle after the first keyframe's answer; the refiner thread (idle scheduling
// class) re-sends that keyframe at a budget above 40 kB, so with the fine settings (JPEG up to q98), as its next
// revision, before every frame was read. The server holds one surface per seq, at the outbox's revision and bytes.
TEST_F(StreamCli, RefinesBetweenKeyframesWhileTrackingAtALargerBudget) {
  const std::string box = dir_ + "/gaps";
  auto cmd = run_command(stream_command(server_.port(), "gaps", box, 2000, "--realtime --keyframe-translation 0.15"));
  ASSERT_EQ(cmd.exit_code, 0) << cmd.out << cmd.err;
  const MissionRun run = summarize(server_.port(), "gaps", box);
  ASSERT_GE(run.outbox.size(), 1u);
  expect_mission_matches_outbox(run);
  EXPECT_GE(count_before(cmd.out, " made while tracking"), 1) << cmd.out;
  // The keep rule as the summary states it: "...; N reduced and not kept, under R x the bytes) of M refinements)".
  const std::string rule = " reduced and not kept, under ";
  const auto rule_at = cmd.out.find(rule);
  ASSERT_NE(rule_at, std::string::npos) << cmd.out;
  const double keep_ratio = std::stod(cmd.out.substr(rule_at + rule.size()));
  EXPECT_GT(keep_ratio, 1.0) << cmd.out;
  int revs = 0;
  bool fine = false;
  for (const auto& e : run.outbox) {
    const int rev = e.value("rev", 0);
    revs += rev;
    if (rev > 0) {
      EXPECT_GE(e["bytes"].get<double>(), keep_ratio * e["first_bytes"].get<double>()) << e.dump();
      fine = fine || e["budget_kb"].get<double>() > 40;
    }
  }
  EXPECT_EQ(revs, count_before(cmd.out, " refinements)")) << cmd.out;
  EXPECT_TRUE(fine) << cmd.out;
  for (const auto& k : run.mission["keyframes"]) {
    for (const auto& e : run.outbox) {
      if (e["seq"] == k["seq"]) {
        EXPECT_EQ(k.value("rev", 0), e.value("rev", 0)) << k.dump();
      }
    }
  }
}

TEST_F(StreamCli, DeferredKeyframesReachTheMissionOnceAfterASenderRestart) {
  // A keyframe at least every 6 frames, at 5 kbit/s: the first keyframe holds the line for seconds (at least the
  // 4 kB budget floor, 6.4 s), so the second waits for the link, and the third, tracked meanwhile, supersedes it.
  const std::string box = dir_ + "/deferred", args = "--keyframe-gap 6 --refine-kb 0";
  const std::string slow = stream_command(server_.port(), "deferred", box, 5, args);
  auto records = [&] { return fs::exists(box) ? outbox_files(box, "deferred-") : std::vector<json>{}; };
  ASSERT_TRUE(stop_when(
                  slow, [&] { return records().size() >= 2; }, 240)
                  .signalled)
      << "the sender ended before two keyframes were deferred";
  std::set<int> deferred_frames;
  int latest_frame = -1;
  for (const auto& r : records()) {
    deferred_frames.insert(r["frame"].get<int>());
    latest_frame = std::max(latest_frame, r["frame"].get<int>());
    EXPECT_EQ(r["pose"].size(), 7u) << r.dump();
  }
  ASSERT_GE(deferred_frames.size(), 2u);
  const auto before = outbox_entries(box);
  for (const auto& e : before) {
    EXPECT_FALSE(deferred_frames.count(e["frame"].get<int>())) << "deferred and added: " << e.dump();
    latest_frame = std::max(latest_frame, e["frame"].get<int>());
  }

  // Again at 5 kbit/s, stopped (SIGINT) 2 s after it started, once it reads frames (its signal handler is set): the
  // link carries a deferred keyframe every few seconds, so some still wait (and keep their records); the exit code
  // says the mission is not complete. Each deferred keyframe of the first run is still deferred or an entry now, not
  // both.
  const auto t0 = std::chrono::steady_clock::now();
  const std::string log = dir_ + "/deferred-stop.log";
  const Stopped stopped = stop_when(
      slow,
      [&] {
        return std::chrono::steady_clock::now() - t0 > std::chrono::seconds(2) &&
               read_file(log).find("rgbdcast stream: frames") != std::string::npos;
      },
      240, SIGINT, log);
  ASSERT_TRUE(stopped.signalled) << read_file(log);
  EXPECT_EQ(stopped.exit_code, 1) << read_file(log);
  std::set<int> waiting;
  for (const auto& r : records()) waiting.insert(r["frame"].get<int>());
  ASSERT_FALSE(waiting.empty()) << read_file(log);
  EXPECT_NE(read_file(log).find(std::to_string(waiting.size()) + " deferred ones wait there to be reduced"),
            std::string::npos)
      << read_file(log);
  const auto entries = outbox_entries(box);
  std::set<int> entry_frames;
  for (const auto& e : entries) {
    entry_frames.insert(e["frame"].get<int>());
    latest_frame = std::max(latest_frame, e["frame"].get<int>());
  }
  for (int f : deferred_frames)
    EXPECT_NE(waiting.count(f), entry_frames.count(f)) << "frame " << f << ": " << read_file(log);
  for (int f : waiting) {
    EXPECT_FALSE(entry_frames.count(f)) << "frame " << f << " deferred and added";
    latest_frame = std::max(latest_frame, f);
  }
  deferred_frames.insert(waiting.begin(), waiting.end());

  // Started again with a link that carries everything.
  auto again = run_command(stream_command(server_.port(), "deferred", box, 2000, args));
  ASSERT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_NE(again.out.find("resumed at frame " + std::to_string(latest_frame) + " after " +
                           std::to_string(entries.size()) + " outbox entries and " + std::to_string(waiting.size()) +
                           " deferred keyframes (" + std::to_string(waiting.size()) + " of them sent, coarsened)"),
            std::string::npos)
      << again.out;
  const MissionRun resumed = summarize(server_.port(), "deferred", box);
  expect_mission_matches_outbox(resumed);  // each seq and each frame once on the server, with the outbox's bytes
  for (size_t i = 0; i < resumed.outbox.size(); ++i) EXPECT_EQ(resumed.outbox[i]["seq"].get<size_t>(), i);
  EXPECT_TRUE(records().empty());
  // Every keyframe ever deferred is an entry now, coarsened; those that waited until this run come after every entry
  // of the runs before. (One whose surface the keyframes before it covered entirely would have nothing to send, and
  // be counted as fully covered; on these frames, 6 apart, none is.)
  std::set<int> sent;
  for (const auto& e : resumed.outbox) {
    const int frame = e["frame"].get<int>();
    if (!deferred_frames.count(frame)) continue;
    sent.insert(frame);
    EXPECT_TRUE(e["coarsened"].get<bool>()) << e.dump();
    if (waiting.count(frame)) {
      EXPECT_GE(e["seq"].get<size_t>(), entries.size()) << e.dump();
    }
  }
  EXPECT_EQ(sent, deferred_frames) << again.out;
}

TEST_F(StreamCli, TheBudgetFollowsALinkKbpsChangedWhileStreaming) {
  // Streams 61 frames at a 2 Mbit/s cap; once the first keyframe is in the outbox the control file says 50 kbit/s.
  // Keyframes reduced before: budgets of at least 14 kB (the first one's estimate is the 500 kbit/s initial guess,
  // and the latency rule leaves its POST at least a quarter of 1 s: 62.5 kB/s x 0.25 s x 0.9). After: at most
  // 6.25 kB/s x 1 s x 0.9 = 5.6 kB (both rules scale with the capped estimate).
  const std::string box = dir_ + "/live", control = dir_ + "/link_kbps";
  { std::ofstream(control) << "2000\n"; }
  // All 120 frames: with the faster reduction, 60 frames could end within 2 s of the change (the margin below).
  // Without refinements: one made at 2 Mbit/s (up to 200 kB) would then take the 50 kbit/s line for half a minute
  // before the run could end, and this test is about the keyframes' budgets.
  const std::string cmd = rgbdcast_binary() + " stream --input " + data_path(kSequence) +
                          " --server http://127.0.0.1:" + std::to_string(server_.port()) + " --mission live --outbox " +
                          box + " --link-kbps 2000 --link-kbps-file " + control + " --seed 5 --refine-kb 0";
  pid_t pid = -1;
  const std::string exec_cmd = "exec " + cmd + " >" + dir_ + "/live.out 2>" + dir_ + "/live.err";
  const char* argv[] = {"/bin/sh", "-c", exec_cmd.c_str(), nullptr};
  ASSERT_EQ(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
  double changed_at = 0;
  int status = -1;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(400);
  while (std::chrono::steady_clock::now() < deadline) {
    if (changed_at == 0 && fs::exists(box) && !outbox_entries(box).empty()) {
      changed_at = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
      std::ofstream(control, std::ios::trunc) << "50\n";
    }
    if (waitpid(pid, &status, WNOHANG) == pid) {
      pid = -1;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (pid > 0) {
    ::kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    FAIL() << "the sender did not finish within 400 s";
  }
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << read_file(dir_ + "/live.err");
  ASSERT_GT(changed_at, 0) << "the stream finished before its first keyframe was seen";
  const std::string out = read_file(dir_ + "/live.out");
  EXPECT_NE(out.find("2 caps read from"), std::string::npos) << out;
  const MissionRun run = summarize(server_.port(), "live", box);
  expect_mission_matches_outbox(run);
  // The first keyframe was made before the change. A keyframe whose pose came 2 s after it (the file is re-read
  // after every frame, and a frame takes well under 2 s) must have the low budget.
  ASSERT_FALSE(run.outbox.empty());
  EXPECT_GE(run.outbox.front()["budget_kb"].get<double>(), 14.0) << run.outbox.front().dump();
  size_t after = 0;
  for (const auto& e : run.outbox) {
    ASSERT_TRUE(e.contains("tracked")) << e.dump();
    if (e["tracked"].get<double>() < changed_at + 2.0) continue;
    ++after;
    EXPECT_LE(e["budget_kb"].get<double>(), 6.25 * 0.9 + 1e-9) << e.dump();
    // Where its time went, in order.
    EXPECT_LE(e["captured"].get<double>(), e["tracked"].get<double>());
    EXPECT_LE(e["tracked"].get<double>(), e["reduced"].get<double>());
    EXPECT_LE(e["reduced"].get<double>(), e["post_started"].get<double>());
  }
  EXPECT_GE(after, 1u) << "no keyframe was made after the change; " << run.outbox.size() << " keyframes";
}

TEST_F(StreamCli, BadInputGetsAOneLineError) {
  const std::string base = rgbdcast_binary() + " stream --input " + data_path(kSequence) + " --outbox " + dir_ + "/bad";
  const std::string server = " --server http://127.0.0.1:" + std::to_string(server_.port());
  struct Case {
    std::string args, expect;
    int exit_code;
  } cases[] = {
      {" --mission m --server http://127.0.0.1:1", "cannot reach", 1},  // unreachable: not the input's fault
      {" --mission m --server 127.0.0.1:8080", "--server must be", 2},
      {" --mission m" + server + " --token-file " + dir_ + "/nope", "token file", 2},
      {" --mission 'bad name'" + server, "--mission must match", 2},
  };
  for (const Case& c : cases) {
    auto r = run_command(base + c.args);
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args << ": " << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir_ + "/bad/mission.json"));  // nothing written before the input was checked
  auto r = run_command(rgbdcast_binary() + " stream --input " + dir_ +
                       "/no-such-source --mission m --server http://127.0.0.1:" + std::to_string(server_.port()));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace
}  // namespace rgbdcast::test
