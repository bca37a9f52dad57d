#include "stream/outbox.h"

#include <Eigen/Geometry>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "base/atomic_file.h"

namespace rgbdcast::stream {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::vector<std::uint8_t> text_bytes(const std::string& s) { return {s.begin(), s.end()}; }

json entry_json(const OutboxEntry& e) {
  json j = {{"seq", e.seq},
            {"frame", e.frame_index},
            {"timestamp", e.timestamp},
            {"pose", e.pose},
            {"captured", e.captured},
            {"budget_kb", e.budget_kb},
            {"bytes", e.bytes},
            {"triangles", e.triangles},
            {"coarsened", e.coarsened},
            {"attempted", e.attempted},
            {"acked", e.acked},
            {"rejected", e.rejected}};
  if (e.rev > 0) {
    j["rev"] = e.rev;
    j["first_bytes"] = e.first_bytes;
    j["first_budget_kb"] = e.first_budget_kb;
    if (!e.first_ack.empty()) j["first_ack"] = json::parse(e.first_ack, nullptr, false);
  }
  if (e.tracked > 0) j["tracked"] = e.tracked;
  if (e.reduced > 0) j["reduced"] = e.reduced;
  if (e.post_started > 0) j["post_started"] = e.post_started;
  if (!e.ack_json.empty()) j["ack"] = json::parse(e.ack_json, nullptr, false);
  return j;
}

Result<OutboxEntry> parse_entry(const std::string& text, const std::string& name) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object())
    return make_error(ErrorCode::kInvalidInput, "outbox entry " + name + " is not JSON");
  try {
    OutboxEntry e;
    e.seq = j.at("seq").get<int>();
    e.frame_index = j.at("frame").get<int>();
    e.timestamp = j.at("timestamp").get<double>();
    e.pose = j.at("pose").get<std::array<double, 7>>();
    e.captured = j.at("captured").get<double>();
    e.budget_kb = j.at("budget_kb").get<double>();
    e.bytes = j.at("bytes").get<size_t>();
    e.triangles = j.value("triangles", size_t{0});
    e.tracked = j.value("tracked", 0.0);
    e.reduced = j.value("reduced", 0.0);
    e.post_started = j.value("post_started", 0.0);
    e.coarsened = j.at("coarsened").get<bool>();
    e.attempted = j.at("attempted").get<bool>();
    e.acked = j.at("acked").get<bool>();
    e.rejected = j.value("rejected", std::string());
    if (j.contains("ack") && j["ack"].is_object()) e.ack_json = j["ack"].dump();
    e.rev = j.value("rev", 0);
    if (e.rev < 0) return make_error(ErrorCode::kInvalidInput, "outbox entry " + name + ": rev < 0");
    e.first_bytes = j.value("first_bytes", size_t{0});
    e.first_budget_kb = j.value("first_budget_kb", 0.0);
    if (j.contains("first_ack") && j["first_ack"].is_object()) e.first_ack = j["first_ack"].dump();
    return e;
  } catch (const json::exception& ex) {
    return make_error(ErrorCode::kInvalidInput, "outbox entry " + name + ": " + ex.what());
  }
}

json deferred_json(const DeferredKeyframe& k) {
  return {{"frame", k.frame_index},
          {"timestamp", k.timestamp},
          {"pose", k.pose},
          {"captured", k.captured},
          {"tracked", k.tracked}};
}

Result<DeferredKeyframe> parse_deferred(const std::string& text, const std::string& name) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object())
    return make_error(ErrorCode::kInvalidInput, "deferred keyframe " + name + " is not JSON");
  try {
    DeferredKeyframe k;
    k.frame_index = j.at("frame").get<int>();
    k.timestamp = j.at("timestamp").get<double>();
    k.pose = j.at("pose").get<std::array<double, 7>>();
    k.captured = j.at("captured").get<double>();
    k.tracked = j.value("tracked", 0.0);
    if (k.frame_index < 0) return make_error(ErrorCode::kInvalidInput, "deferred keyframe " + name + ": frame < 0");
    return k;
  } catch (const json::exception& ex) {
    return make_error(ErrorCode::kInvalidInput, "deferred keyframe " + name + ": " + ex.what());
  }
}

Result<std::string> read_text(const std::string& path) {
  auto bytes = read_file_bytes(path, 1 << 20);
  if (!bytes) return bytes.error();
  return std::string(bytes->begin(), bytes->end());
}

// The files `<prefix>*.json` of dir, each with its text.
struct JsonFile {
  fs::path path;
  std::string text;
};
Result<std::vector<JsonFile>> read_json_files(const std::string& dir, const std::string& prefix) {
  std::error_code ec;
  std::vector<JsonFile> out;
  for (const auto& item : fs::directory_iterator(dir, ec)) {
    if (item.path().filename().string().rfind(prefix, 0) != 0 || item.path().extension() != ".json") continue;
    auto text = read_text(item.path().string());
    if (!text) return text.error();
    out.push_back({item.path(), std::move(*text)});
  }
  if (ec) return make_error(ErrorCode::kIo, "outbox " + dir + ": " + ec.message());
  return out;
}

}  // namespace

Result<std::unique_ptr<Outbox>> Outbox::open(const std::string& dir, const std::string& mission) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, "outbox " + dir + ": " + ec.message());
  std::unique_ptr<Outbox> box(new Outbox(dir, mission));
  const std::string mission_path = (fs::path(dir) / "mission.json").string();
  if (fs::exists(mission_path)) {
    auto text = read_text(mission_path);
    if (!text) return text.error();
    json j = json::parse(*text, nullptr, false);
    if (j.is_discarded() || !j.contains("mission") || !j["mission"].is_string())
      return make_error(ErrorCode::kInvalidInput, "outbox " + mission_path + " is not an outbox's mission.json");
    if (j["mission"].get<std::string>() != mission)
      return make_error(ErrorCode::kInvalidArgument, "outbox " + dir + " holds mission '" +
                                                         j["mission"].get<std::string>() + "', not '" + mission + "'");
  } else if (auto st = write_file_atomically(mission_path, text_bytes(json{{"mission", mission}}.dump() + "\n")); !st) {
    return st.error();
  }
  auto entry_files = read_json_files(dir, "kf-");
  if (!entry_files) return entry_files.error();
  for (const JsonFile& file : *entry_files) {
    auto e = parse_entry(file.text, file.path.string());
    if (!e) return e.error();
    if (!fs::exists(box->glb_path(e->seq, e->rev)))
      return make_error(ErrorCode::kInvalidInput,
                        "outbox entry " + file.path.filename().string() + " has no GLB beside it");
    e->bytes = fs::file_size(box->glb_path(e->seq, e->rev));  // a coarsening cut short between its two writes
    box->entries_[e->seq] = std::move(*e);
  }
  // Deferred keyframes; one whose frame has an entry was added, and the crash came before its record was removed.
  std::set<int> entry_frames;
  for (const auto& [seq, e] : box->entries_) entry_frames.insert(e.frame_index);
  auto deferred_files = read_json_files(dir, "deferred-");
  if (!deferred_files) return deferred_files.error();
  for (const JsonFile& file : *deferred_files) {
    auto k = parse_deferred(file.text, file.path.string());
    if (!k) return k.error();
    if (entry_frames.count(k->frame_index))
      fs::remove(file.path, ec);
    else
      box->deferred_[k->frame_index] = *k;
  }
  // A GLB without its JSON was never sent: its seq is free again. A GLB that is not its entry's current revision
  // is a revision cut short (before its JSON) or one replaced (before the older GLB was removed).
  for (const auto& item : fs::directory_iterator(dir, ec)) {
    const std::string name = item.path().filename().string();
    if (name.rfind("kf-", 0) != 0 || item.path().extension() != ".glb") continue;
    int seq = -1, rev = 0;
    if (std::sscanf(name.c_str(), "kf-%d.r%d.glb", &seq, &rev) < 1) continue;
    auto it = box->entries_.find(seq);
    if (it == box->entries_.end() || fs::path(box->glb_path(seq, it->second.rev)).filename() != item.path().filename())
      fs::remove(item.path(), ec);
  }
  return box;
}

std::string Outbox::path(int seq, const char* ext) const {
  char name[32];
  std::snprintf(name, sizeof name, "kf-%08d%s", seq, ext);
  return (fs::path(dir_) / name).string();
}

std::string Outbox::glb_path(int seq, int rev) const {
  if (rev == 0) return path(seq, ".glb");
  return path(seq, (".r" + std::to_string(rev) + ".glb").c_str());
}

Status Outbox::write_meta(const OutboxEntry& e) const {
  return write_file_atomically(path(e.seq, ".json"), text_bytes(entry_json(e).dump(1) + "\n"));
}

std::vector<OutboxEntry> Outbox::entries() const {
  std::lock_guard lock(mu_);
  std::vector<OutboxEntry> out;
  for (const auto& [seq, e] : entries_) out.push_back(e);
  return out;
}

std::optional<OutboxEntry> Outbox::entry(int seq) const {
  std::lock_guard lock(mu_);
  auto it = entries_.find(seq);
  if (it == entries_.end()) return std::nullopt;
  return it->second;
}

int Outbox::next_seq() const {
  std::lock_guard lock(mu_);
  return entries_.empty() ? 0 : entries_.rbegin()->first + 1;
}

Result<OutboxEntry> Outbox::add(OutboxEntry e, const std::vector<std::uint8_t>& glb) {
  std::lock_guard lock(mu_);
  e.seq = entries_.empty() ? 0 : entries_.rbegin()->first + 1;
  e.bytes = glb.size();
  e.attempted = e.acked = false;
  if (auto st = write_file_atomically(path(e.seq, ".glb"), glb); !st) return st.error();
  if (auto st = write_meta(e); !st) return st.error();
  entries_[e.seq] = e;
  if (deferred_.count(e.frame_index))
    (void)remove_deferred_locked(e.frame_index);  // open() removes it, should this fail
  return e;
}

Status Outbox::coarsen(int seq, const std::vector<std::uint8_t>& glb, double budget_kb, size_t triangles) {
  std::lock_guard lock(mu_);
  auto it = entries_.find(seq);
  if (it == entries_.end()) return make_error(ErrorCode::kNotFound, "outbox: no keyframe " + std::to_string(seq));
  if (it->second.attempted)
    return make_error(ErrorCode::kInvalidArgument, "outbox: keyframe " + std::to_string(seq) + " was already sent");
  if (it->second.rev > 0)
    return make_error(ErrorCode::kInvalidArgument, "outbox: keyframe " + std::to_string(seq) + " is a refinement");
  OutboxEntry e = it->second;
  e.bytes = glb.size();
  e.budget_kb = budget_kb;
  e.triangles = triangles;
  e.coarsened = true;
  if (auto st = write_file_atomically(glb_path(seq, e.rev), glb); !st) return st;
  if (auto st = write_meta(e); !st) return st;
  it->second = e;
  return ok_status();
}

Status Outbox::revise(int seq, const std::vector<std::uint8_t>& glb, double budget_kb, size_t triangles) {
  return revise_entry(seq, glb, budget_kb, triangles, false);
}

Status Outbox::revise_in_flight(int seq, const std::vector<std::uint8_t>& glb, double budget_kb, size_t triangles) {
  return revise_entry(seq, glb, budget_kb, triangles, true);
}

Status Outbox::revise_entry(int seq, const std::vector<std::uint8_t>& glb, double budget_kb, size_t triangles,
                            bool in_flight) {
  std::lock_guard lock(mu_);
  auto it = entries_.find(seq);
  if (it == entries_.end()) return make_error(ErrorCode::kNotFound, "outbox: no keyframe " + std::to_string(seq));
  const OutboxEntry& now = it->second;
  if (!in_flight && !now.acked)
    return make_error(ErrorCode::kInvalidArgument,
                      "outbox: keyframe " + std::to_string(seq) + " is not acknowledged yet: nothing to revise");
  if (in_flight && !(now.attempted && now.pending()))
    return make_error(ErrorCode::kInvalidArgument,
                      "outbox: keyframe " + std::to_string(seq) + " has no POST out: nothing to revise beside it");
  OutboxEntry e = now;
  if (e.rev == 0) {
    e.first_bytes = e.bytes;
    e.first_budget_kb = e.budget_kb;
    e.first_ack = e.ack_json;  // empty when in flight: its answer fills it (mark_acked)
  }
  ++e.rev;
  e.bytes = glb.size();
  e.budget_kb = budget_kb;
  e.triangles = triangles;
  e.attempted = e.acked = false;
  e.ack_json.clear();
  if (auto st = write_file_atomically(glb_path(seq, e.rev), glb); !st) return st;
  if (auto st = write_meta(e); !st) {
    std::error_code ec;
    fs::remove(glb_path(seq, e.rev), ec);
    return st;
  }
  std::error_code ec;
  fs::remove(glb_path(seq, it->second.rev), ec);  // open() would remove it, should this fail
  it->second = e;
  return ok_status();
}

Status Outbox::update(int seq, const std::function<void(OutboxEntry&)>& change) {
  std::lock_guard lock(mu_);
  auto it = entries_.find(seq);
  if (it == entries_.end()) return make_error(ErrorCode::kNotFound, "outbox: no keyframe " + std::to_string(seq));
  OutboxEntry e = it->second;
  change(e);
  if (auto st = write_meta(e); !st) return st;  // the index changes only once the file did
  it->second = e;
  return ok_status();
}

Status Outbox::mark_attempted(int seq, double post_started, int rev) {
  if (auto e = entry(seq); e && (e->attempted || (rev >= 0 && e->rev > rev))) return ok_status();
  return update(seq, [&](OutboxEntry& e) {
    e.attempted = true;
    if (e.post_started <= 0) e.post_started = post_started;
  });
}

Status Outbox::mark_acked(int seq, const std::string& ack_json, int rev) {
  return update(seq, [&](OutboxEntry& e) {
    if (rev >= 0 && e.rev > rev) {  // an older revision's answer: the newer one is still to be answered
      if (rev == 0 && e.first_ack.empty()) e.first_ack = ack_json;
      return;
    }
    e.attempted = e.acked = true;
    e.ack_json = ack_json;
  });
}

Status Outbox::mark_rejected(int seq, const std::string& reason, int rev) {
  if (auto e = entry(seq); e && rev >= 0 && e->rev > rev) return ok_status();  // the newer revision is posted
  return update(seq, [&](OutboxEntry& e) { e.rejected = reason.empty() ? "rejected" : reason; });
}

Result<std::vector<std::uint8_t>> Outbox::read_glb(int seq) const {
  int rev = 0;
  {
    std::lock_guard lock(mu_);
    auto it = entries_.find(seq);
    if (it != entries_.end()) rev = it->second.rev;
  }
  return read_glb(seq, rev);
}

Result<std::vector<std::uint8_t>> Outbox::read_glb(int seq, int rev) const {
  return read_file_bytes(glb_path(seq, rev), size_t{1} << 30);
}

std::string Outbox::deferred_path(int frame_index) const {
  char name[40];
  std::snprintf(name, sizeof name, "deferred-%08d.json", frame_index);
  return (fs::path(dir_) / name).string();
}

Status Outbox::defer(const DeferredKeyframe& k) {
  if (k.frame_index < 0) return make_error(ErrorCode::kInvalidArgument, "outbox: a deferred keyframe needs a frame");
  std::lock_guard lock(mu_);
  if (auto st = write_file_atomically(deferred_path(k.frame_index), text_bytes(deferred_json(k).dump(1) + "\n")); !st)
    return st;
  deferred_[k.frame_index] = k;
  return ok_status();
}

Status Outbox::remove_deferred_locked(int frame_index) {
  std::error_code ec;
  fs::remove(deferred_path(frame_index), ec);
  if (ec)
    return make_error(ErrorCode::kIo,
                      "outbox: removing deferred keyframe " + std::to_string(frame_index) + ": " + ec.message());
  deferred_.erase(frame_index);
  return ok_status();
}

Status Outbox::undefer(int frame_index) {
  std::lock_guard lock(mu_);
  return remove_deferred_locked(frame_index);
}

std::vector<DeferredKeyframe> Outbox::deferred() const {
  std::lock_guard lock(mu_);
  std::vector<DeferredKeyframe> out;
  for (const auto& [frame, k] : deferred_) out.push_back(k);
  return out;
}

std::array<double, 7> pose_to_tum(const double* m) {
  const Eigen::Map<const Eigen::Matrix4d> pose(m);
  Eigen::Quaterniond q(Eigen::Matrix3d(pose.topLeftCorner<3, 3>()));
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1;
  return {pose(0, 3), pose(1, 3), pose(2, 3), q.x(), q.y(), q.z(), q.w()};
}

std::string pose_query(const std::array<double, 7>& p) {
  std::ostringstream s;
  s.precision(10);
  for (size_t i = 0; i < p.size(); ++i) s << (i ? "," : "") << p[i];
  return s.str();
}

}  // namespace rgbdcast::stream
