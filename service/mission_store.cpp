#include "service/mission_store.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "base/atomic_file.h"
#include "base/stopwatch.h"
#include "service/mission_index.h"
#include "service/scene_store.h"  // read_text, quarantine, etag_of

namespace fs = std::filesystem;

namespace rgbdcast::service {
namespace {

constexpr const char* kDeletingPrefix = ".deleting-";

bool is_seq_stem(const std::string& s) {
  if (s.empty() || s.size() > 10) return false;
  if (!std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; })) return false;
  if (s.size() > 1 && s[0] == '0') return false;
  return std::stoll(s) <= kMaxKeyframeSeq;
}

// "<seq>.glb" for rev 0 (as before revisions existed), "<seq>.r<rev>.glb" after.
std::string glb_name(std::int64_t seq, std::int64_t rev) {
  return rev == 0 ? std::to_string(seq) + ".glb" : std::to_string(seq) + ".r" + std::to_string(rev) + ".glb";
}

// The (seq, rev) of a GLB file name made by glb_name; nullopt for any other name.
std::optional<std::pair<std::int64_t, std::int64_t>> parse_glb_name(const std::string& file) {
  if (file.size() < 5 || file.compare(file.size() - 4, 4, ".glb") != 0) return std::nullopt;
  const std::string stem = file.substr(0, file.size() - 4);
  const auto dot = stem.find(".r");
  const std::string seq = stem.substr(0, dot);
  if (!is_seq_stem(seq)) return std::nullopt;
  if (dot == std::string::npos) return std::make_pair(std::stoll(seq), std::int64_t{0});
  const std::string rev = stem.substr(dot + 2);
  if (!is_seq_stem(rev) || rev == "0") return std::nullopt;
  return std::make_pair(std::stoll(seq), std::stoll(rev));
}

}  // namespace

nlohmann::json stored_keyframe_json(const MissionKeyframe& k) {
  nlohmann::json j = k.entry();
  j["mission"] = k.mission;
  j["etag"] = k.etag;
  j["camera"] = k.camera;
  if (k.available <= 0) j.erase("available");
  if (k.first_available <= 0) j.erase("first_available");
  return j;
}

// A keyframe JSON file: every field present with its type, or kInvalidInput with the reason.
Result<MissionKeyframe> parse_stored_keyframe(const std::string& name, std::int64_t seq, const std::string& text) {
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  auto bad = [](const std::string& why) { return make_error(ErrorCode::kInvalidInput, why); };
  if (j.is_discarded() || !j.is_object()) return bad("keyframe metadata is not a JSON object");
  auto number = [&](const char* key) { return j.contains(key) && j[key].is_number(); };
  for (const char* key : {"seq", "bytes", "triangles", "captured", "received"})
    if (!number(key)) return bad(std::string("keyframe metadata lacks the number '") + key + "'");
  if (!j.contains("mission") || !j["mission"].is_string() || j["mission"] != name)
    return bad("keyframe metadata names another mission");
  if (!j["seq"].is_number_integer() || j["seq"].get<std::int64_t>() != seq)
    return bad("keyframe metadata names another seq");
  if (!j.contains("etag") || !j["etag"].is_string()) return bad("keyframe metadata lacks its etag");
  if (!j.contains("camera") || !j["camera"].is_object()) return bad("keyframe metadata lacks its camera");
  if (!j.contains("pose") || !j["pose"].is_array() || j["pose"].size() != 7) return bad("pose is not 7 numbers");
  MissionKeyframe k;
  for (size_t i = 0; i < 7; ++i) {
    if (!j["pose"][i].is_number()) return bad("pose is not 7 numbers");
    k.pose[i] = j["pose"][i].get<double>();
    if (!std::isfinite(k.pose[i])) return bad("pose is not finite");
  }
  if (j.contains("available") && !j["available"].is_number()) return bad("'available' is not a number");
  if (j.contains("first_available") && !j["first_available"].is_number())
    return bad("'first_available' is not a number");
  if (j.contains("rev") && (!j["rev"].is_number_integer() || j["rev"].get<std::int64_t>() < 0 ||
                            j["rev"].get<std::int64_t>() > kMaxKeyframeSeq))
    return bad("'rev' is not a revision 0..2^31-1");
  if (!j["bytes"].is_number_unsigned() || !j["triangles"].is_number_unsigned())
    return bad("bytes and triangles must be counts");
  k.mission = name;
  k.seq = seq;
  k.bytes = j["bytes"].get<std::uint64_t>();
  k.triangles = j["triangles"].get<std::uint64_t>();
  k.captured = j["captured"].get<double>();
  k.received = j["received"].get<double>();
  k.available = j.value("available", 0.0);
  k.first_available = j.value("first_available", k.available);
  k.rev = j.value("rev", std::int64_t{0});
  k.etag = j["etag"].get<std::string>();
  k.camera = j["camera"];
  return k;
}

namespace {

Status write_json(const std::string& dir, std::int64_t seq, const MissionKeyframe& k) {
  const std::string text = stored_keyframe_json(k).dump(2);
  return write_file_atomically(dir + "/" + std::to_string(seq) + ".json", text.data(), text.size());
}

}  // namespace

bool is_valid_mission_name(std::string_view name) {
  if (name.empty() || name.size() > 64) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

nlohmann::json MissionKeyframe::answer() const {
  return {{"mission", mission},
          {"seq", seq},
          {"rev", rev},
          {"bytes", bytes},
          {"triangles", triangles},
          {"captured", captured},
          {"received", received},
          {"available", available},
          {"first_available", first_available}};
}

nlohmann::json MissionKeyframe::entry() const {
  return {{"seq", seq},
          {"rev", rev},
          {"pose", pose},
          {"bytes", bytes},
          {"triangles", triangles},
          {"captured", captured},
          {"received", received},
          {"available", available},
          {"first_available", first_available}};
}

std::string MissionKeyframe::event_id() const {
  return rev == 0 ? std::to_string(seq) : std::to_string(seq) + "-" + std::to_string(rev);
}

std::optional<MissionEventId> parse_event_id(const std::string& text) {
  const auto dash = text.find('-');
  const std::string seq = text.substr(0, dash);
  auto number = [](const std::string& s) -> std::optional<std::int64_t> {
    if (s.empty() || s.size() > 10 || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
      return std::nullopt;
    const std::int64_t v = std::stoll(s);
    if (v > kMaxKeyframeSeq) return std::nullopt;
    return v;
  };
  auto s = number(seq);
  if (!s) return std::nullopt;
  MissionEventId id{*s, 0};
  if (dash != std::string::npos) {
    auto r = number(text.substr(dash + 1));
    if (!r) return std::nullopt;
    id.rev = *r;
  }
  return id;
}

MissionStore::MissionStore() : index_(std::make_unique<MissionIndex>()) {}
MissionStore::~MissionStore() = default;

Result<std::unique_ptr<MissionStore>> MissionStore::open(const std::string& data_dir) {
  auto store = DirectoryMissionStore::open(data_dir);
  if (!store) return store.error();
  return std::unique_ptr<MissionStore>(std::move(*store));
}

void MissionStore::set_tileset_version(const std::string& name, std::uint64_t version) {
  index_->set_tileset_version(name, version);
}
std::vector<MissionSummary> MissionStore::list() const { return index_->list(); }
std::optional<std::vector<MissionKeyframe>> MissionStore::keyframes(const std::string& name) const {
  return index_->keyframes(name);
}
std::optional<std::vector<MissionKeyframe>> MissionStore::arrivals(const std::string& name) const {
  return index_->arrivals(name);
}
std::optional<EventCursor> MissionStore::cursor_after(const std::string& name,
                                                      std::optional<MissionEventId> last_event_id) const {
  return index_->cursor_after(name, last_event_id);
}
EventBatch MissionStore::wait_events(const std::string& name, EventCursor& cursor, std::chrono::milliseconds timeout) {
  return index_->wait_events(name, cursor, timeout);
}
void MissionStore::wake_all() { index_->wake_all(); }
size_t MissionStore::count() const { return index_->count(); }

Status check_keyframe_key(const MissionKeyframe& k) {
  if (!is_valid_mission_name(k.mission))
    return make_error(ErrorCode::kInvalidArgument, "mission name must be 1..64 of A-Z a-z 0-9 _ -");
  if (k.seq < 0 || k.seq > kMaxKeyframeSeq) return make_error(ErrorCode::kInvalidArgument, "seq must be 0..2^31-1");
  if (k.rev < 0 || k.rev > kMaxKeyframeSeq) return make_error(ErrorCode::kInvalidArgument, "rev must be 0..2^31-1");
  return ok_status();
}

PutOutcome repeat_outcome(const MissionKeyframe& stored, const MissionKeyframe& k, bool same_bytes) {
  if (k.rev < stored.rev) return PutOutcome::kStale;
  return same_bytes && stored.etag == k.etag && stored.pose == k.pose ? PutOutcome::kSame : PutOutcome::kConflict;
}

Result<std::unique_ptr<DirectoryMissionStore>> DirectoryMissionStore::open(const std::string& data_dir) {
  if (data_dir.empty()) return make_error(ErrorCode::kInvalidArgument, "data dir is empty");
  const std::string dir = (fs::path(data_dir) / "missions").string();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, "cannot create " + dir + ": " + ec.message());
  std::unique_ptr<DirectoryMissionStore> store(new DirectoryMissionStore(data_dir, dir));
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(kDeletingPrefix, 0) == 0) {  // a remove() that did not finish
      fs::remove_all(entry.path(), ec);
      store->cleaned_.push_back(name);
    } else if (entry.is_directory() && is_valid_mission_name(name)) {
      names.push_back(name);
    }
  }
  if (ec) return make_error(ErrorCode::kIo, "cannot list " + dir + ": " + ec.message());
  for (const auto& name : names)
    if (auto st = store->load_mission(name); !st) return st.error();
  return store;
}

Status DirectoryMissionStore::load_mission(const std::string& name) {
  const std::string dir = mission_dir(name);
  std::error_code ec;
  std::vector<fs::path> glbs;
  std::vector<std::pair<std::string, std::string>> bad;  // stem, why
  std::map<std::int64_t, MissionKeyframe> by_seq;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string file = entry.path().filename().string();
    if (file.rfind(kTempFilePrefix, 0) == 0) {
      fs::remove(entry.path(), ec);
      cleaned_.push_back(name + "/" + file);
      continue;
    }
    const std::string stem = entry.path().stem().string(), ext = entry.path().extension().string();
    if (ext == ".glb" && parse_glb_name(file)) {
      glbs.push_back(entry.path());
      continue;
    }
    if (!is_seq_stem(stem)) continue;  // not ours: left alone
    if (ext == ".json") {
      auto text = read_text(entry.path().string());
      if (!text) return text.error();
      auto k = parse_stored_keyframe(name, std::stoll(stem), *text);
      if (!k) {
        bad.emplace_back(stem, k.error().message);
        continue;
      }
      by_seq.emplace(k->seq, std::move(*k));
    }
  }
  if (ec) return make_error(ErrorCode::kIo, "cannot list mission " + name + ": " + ec.message());
  for (const auto& [stem, why] : bad) {
    if (auto st = quarantine(data_dir_, dir, stem, "mission-" + name + "-"); !st) return st;
    quarantined_.push_back("mission " + name + " keyframe " + stem + ": " + why + " (moved to quarantine/)");
  }
  // A GLB that is not its keyframe's current revision was never committed (a put() cut short before its JSON) or
  // was replaced (a replacement cut short before the old GLB was removed).
  for (const auto& glb : glbs) {
    const auto key = parse_glb_name(glb.filename().string());
    auto it = by_seq.find(key->first);
    if ((it == by_seq.end() || it->second.rev != key->second) && fs::exists(glb, ec)) {
      fs::remove(glb, ec);
      cleaned_.push_back(name + "/" + glb.filename().string());
    }
  }
  for (auto it = by_seq.begin(); it != by_seq.end();) {  // nor is a JSON without its GLB
    const std::string stem = std::to_string(it->first);
    if (!fs::exists(dir + "/" + glb_name(it->first, it->second.rev), ec)) {
      fs::remove(dir + "/" + stem + ".json", ec);
      cleaned_.push_back(name + "/" + stem + ".json");
      it = by_seq.erase(it);
    } else {
      ++it;
    }
  }
  if (!cleaned_.empty()) {
    if (auto st = fsync_dir(dir); !st) return st;
  }
  if (by_seq.empty()) {  // an empty folder: what a remove() or a first put() cut short leaves
    fs::remove_all(dir, ec);
    return ok_status();
  }
  index().load(name, std::move(by_seq), unix_seconds_now());
  return ok_status();
}

DirectoryMissionStore::~DirectoryMissionStore() { wake_all(); }

Result<PutResult> DirectoryMissionStore::put(MissionKeyframe k, const std::vector<std::uint8_t>& glb) {
  if (auto st = check_keyframe_key(k); !st) return st.error();
  k.bytes = glb.size();
  k.etag = etag_of(glb.data(), glb.size());
  k.available = 0.0;
  k.first_available = 0.0;
  std::lock_guard writer(write_mutex_);
  const std::optional<MissionKeyframe> existing = index().find(k.mission, k.seq);
  if (existing && k.rev <= existing->rev) {
    bool same = k.rev == existing->rev && existing->etag == k.etag && existing->pose == k.pose;
    if (same) {  // the ETag is a 64-bit hash: the bytes decide
      auto stored = read_glb(k.mission, k.seq, k.rev);
      same = stored && *stored == glb;
    }
    return PutResult{repeat_outcome(*existing, k, same), *existing};
  }
  if (existing) k.first_available = existing->first_available;  // a revision: the seq was viewable since then
  const std::string dir = mission_dir(k.mission);
  std::error_code ec;
  const bool fresh_dir = !fs::exists(dir, ec);
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, "cannot create the folder of mission " + k.mission + ": " + ec.message());
  if (fresh_dir) {
    if (auto st = fsync_dir(dir_); !st) return st.error();
  }
  const std::string name = glb_name(k.seq, k.rev);
  if (auto st = write_file_atomically(dir + "/" + name, glb.data(), glb.size()); !st) return st.error();
  if (auto st = write_json(dir, k.seq, k); !st) {
    fs::remove(dir + "/" + name, ec);
    return st.error();
  }
  index().upsert(k);
  if (!existing) return PutResult{PutOutcome::kCreated, k};
  // The replaced revision's GLB: the JSON no longer names it (open() would remove it, should this fail).
  fs::remove(dir + "/" + glb_name(k.seq, existing->rev), ec);
  return PutResult{PutOutcome::kReplaced, k};
}

Status DirectoryMissionStore::mark_available(const std::string& name, std::int64_t seq, double available_unix_s) {
  std::lock_guard writer(write_mutex_);
  std::optional<MissionKeyframe> held = index().find(name, seq);
  if (!held) return make_error(ErrorCode::kNotFound, "no keyframe " + std::to_string(seq) + " in mission " + name);
  MissionKeyframe k = *held;
  if (k.available > 0) return ok_status();
  k.available = available_unix_s;
  if (k.first_available <= 0) k.first_available = available_unix_s;
  // The time is kept in memory and in the events even if this write fails: the keyframe is stored either way.
  Status st = write_json(mission_dir(name), seq, k);
  index().set_available(name, seq, k.rev, available_unix_s);
  return st;
}

Result<std::vector<std::uint8_t>> DirectoryMissionStore::read_glb(const std::string& name, std::int64_t seq,
                                                                  std::int64_t rev) const {
  auto missing = [&] {
    return make_error(ErrorCode::kNotFound, "no keyframe " + std::to_string(seq) + " revision " + std::to_string(rev) +
                                                " in mission " + name);
  };
  if (!is_valid_mission_name(name) || seq < 0 || seq > kMaxKeyframeSeq || rev < 0 || rev > kMaxKeyframeSeq)
    return missing();
  std::ifstream in(mission_dir(name) + "/" + glb_name(seq, rev), std::ios::binary);
  if (!in) return missing();
  return std::vector<std::uint8_t>((std::istreambuf_iterator<char>(in)), {});
}

Status DirectoryMissionStore::remove(const std::string& name) {
  if (!is_valid_mission_name(name)) return make_error(ErrorCode::kNotFound, "no mission " + name);
  std::lock_guard writer(write_mutex_);
  if (!index().contains(name)) return make_error(ErrorCode::kNotFound, "no mission " + name);
  // One rename takes the whole mission away; what follows only frees the space.
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  const std::string gone = dir_ + "/" + kDeletingPrefix + name + "-" + std::to_string(rng() % 1000000000);
  std::error_code ec;
  fs::rename(mission_dir(name), gone, ec);
  if (ec) return make_error(ErrorCode::kIo, "cannot delete mission " + name + ": " + ec.message());
  if (auto st = fsync_dir(dir_); !st) return st;
  index().erase(name);
  fs::remove_all(gone, ec);
  return ok_status();
}

}  // namespace rgbdcast::service
