#include "service/mission_routes.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <regex>
#include <set>

#include "base/stopwatch.h"
#include "gltf/gltf_io.h"
#include "service/connection_gate.h"
#include "service/http_gzip.h"
#include "service/mission_export.h"
#include "service/mission_scene.h"
#include "service/mission_view.h"
#include "service/model_flavors.h"
#include "service/scene_ingest.h"
#include "service/scene_store.h"  // etag_of
#include "tiles/tileset_json.h"

namespace rgbdcast::service {
namespace {

// The mission named by the route's first capture, or a 400 answered.
std::optional<std::string> name_or_error(const httplib::Request& req, httplib::Response& res) {
  const std::string name = req.matches.size() > 1 ? req.matches[1].str() : std::string();
  if (!is_valid_mission_name(name)) {
    send_error(res, 400, "malformed mission name (expected 1..64 of A-Z a-z 0-9 _ -)");
    return std::nullopt;
  }
  return name;
}

// A sequence number or event id: decimal digits, 0..2^31-1.
std::optional<std::int64_t> parse_seq(const std::string& text) {
  if (text.empty() || text.size() > 10) return std::nullopt;
  if (!std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; })) return std::nullopt;
  const std::int64_t v = std::stoll(text);
  if (v > kMaxKeyframeSeq) return std::nullopt;
  return v;
}

}  // namespace

Result<KeyframePage> parse_keyframe_page(const std::multimap<std::string, std::string>& params) {
  KeyframePage page;
  for (const auto& [k, v] : params) {
    if (k != "after" && k != "limit")
      return make_error(ErrorCode::kInvalidArgument, "unknown parameter " + quote_for_error(k) + " (after, limit)");
    if (params.count(k) != 1) return make_error(ErrorCode::kInvalidArgument, k + ": given more than once");
    auto n = parse_seq(v);
    if (k == "after") {
      if (!n) return make_error(ErrorCode::kInvalidArgument, "after: must be a keyframe seq 0..2^31-1");
      page.after = *n;
    } else {
      if (!n || *n < 1 || *n > static_cast<std::int64_t>(kMaxKeyframePage))
        return make_error(ErrorCode::kInvalidArgument,
                          "limit: must be an integer 1.." + std::to_string(kMaxKeyframePage));
      page.limit = static_cast<size_t>(*n);
    }
  }
  return page;
}

namespace {

std::string event_text(const MissionKeyframe& k) {
  return "id: " + k.event_id() + "\nevent: keyframe\ndata: " + k.answer().dump() + "\n\n";
}

// A "tileset" event has no id: Last-Event-ID keeps naming the last keyframe event, and a stream reports the current
// tileset version when it starts anyway.
std::string tileset_event_text(std::uint64_t version, const std::shared_ptr<const tiles::TilesetSnapshot>& s) {
  nlohmann::json data = {{"version", version}};
  if (s && s->version == version) {
    data["tiles"] = s->tiles;
    data["triangles"] = s->triangles;
    data["bytes"] = s->bytes;
    data["keyframes"] = s->keyframes.size();  // the page knows when the tileset holds the keyframes it has listed
  }
  return "event: tileset\ndata: " + data.dump() + "\n\n";
}

// A tile file name as TileRecord::file() makes it: "<level>_<x>_<z>.v<version>.glb", a leaf's
// "0_<x>_<z>_<keyframe>.v<version>.glb".
bool is_tile_file_name(const std::string& f) {
  static const std::regex kTile(R"(\d{1,2}_-?\d{1,13}_-?\d{1,13}(_\d{1,16})?\.v\d{1,19}\.glb)");
  return f.size() <= 80 && std::regex_match(f, kTile);
}

}  // namespace

std::string mission_scene_key(const std::string& name) { return "mission/" + name; }

MissionRoutes::MissionRoutes(MissionRouteOptions options, MissionStore& missions, MissionTiles& tiles, RenderPool& pool,
                             Slots& uploads, RenderView render_view)
    : options_(options),
      missions_(missions),
      tiles_(tiles),
      pool_(pool),
      uploads_(uploads),
      render_view_(std::move(render_view)),
      streams_(options.max_event_streams) {}

MissionRoutes::~MissionRoutes() { stop(); }

void MissionRoutes::stop() {
  stopping_ = true;
  missions_.wake_all();
}

void MissionRoutes::install(httplib::Server& server, const Guard& guard, const GuardReader& guard_reader) {
  using Req = const httplib::Request&;
  using Res = httplib::Response&;
  server.Get(
      "/v1/missions", guard([this](Req, Res res) {
        nlohmann::json list = nlohmann::json::array();
        for (const auto& m : missions_.list())
          list.push_back({{"name", m.name}, {"keyframes", m.keyframes}, {"bytes", m.bytes}, {"updated", m.updated}});
        send_json(res, 200, {{"count", list.size()}, {"missions", list}});
      }));
  server.Post(R"(/v1/missions/([^/]+)/keyframes)",
              guard_reader(
                  [this](Req req, Res res, const httplib::ContentReader& reader) { post_keyframe(req, res, reader); }));
  server.Get(R"(/v1/missions/([^/]+))", guard([this](Req req, Res res) { get_mission(req, res); }));
  server.Delete(R"(/v1/missions/([^/]+))", guard([this](Req req, Res res) { delete_mission(req, res); }));
  server.Get(R"(/v1/missions/([^/]+)/model\.glb)", guard([this](Req req, Res res) { get_model(req, res); }));
  server.Get(R"(/v1/missions/([^/]+)/view)", guard([this](Req req, Res res) { get_view(req, res); }));
  server.Post(R"(/v1/missions/([^/]+)/view)", guard([this](Req req, Res res) { get_view(req, res); }));
  server.Get(R"(/v1/missions/([^/]+)/events)", guard([this](Req req, Res res) { get_events(req, res); }));
  server.Get(R"(/v1/missions/([^/]+)/tileset\.json)", guard([this](Req req, Res res) { get_tileset(req, res); }));
  server.Get(R"(/v1/missions/([^/]+)/tiles/(.*))", guard([this](Req req, Res res) { get_tile(req, res); }));
}

void MissionRoutes::post_keyframe(const httplib::Request& req, httplib::Response& res,
                                  const httplib::ContentReader& reader) {
  const double received = unix_seconds_now();
  // Everything the query says is checked before the body is read; a refusal closes the connection (the unread body
  // is not taken for the next request).
  auto refuse = [&](int status, const std::string& detail) {
    GatedServer::close_after_response();
    send_error(res, status, detail);
  };
  auto name = name_or_error(req, res);
  if (!name) return GatedServer::close_after_response();
  static const std::set<std::string> kKnown = {"seq", "rev", "pose", "captured"};
  std::map<std::string, std::string> q;
  for (const auto& [k, v] : req.params) {
    if (!kKnown.count(k)) return refuse(400, "unknown parameter '" + k.substr(0, 40) + "' (seq, rev, pose, captured)");
    if (!q.emplace(k, v).second) return refuse(400, k + ": given more than once");
  }
  if (!q.count("seq")) return refuse(400, "seq: missing (the keyframe's sequence number, 0..2^31-1)");
  auto seq = parse_seq(q["seq"]);
  if (!seq) return refuse(400, "seq: must be an integer 0..2^31-1");
  std::int64_t rev = 0;  // a revision replaces the stored keyframe of this seq when it is higher (MissionStore)
  if (q.count("rev")) {
    auto r = parse_seq(q["rev"]);
    if (!r) return refuse(400, "rev: must be an integer 0..2^31-1");
    rev = *r;
  }
  auto pose = parse_mission_pose(q.count("pose") ? q["pose"] : std::string());
  if (!pose) return refuse(400, pose.error().message);
  double captured = received;
  if (q.count("captured")) {
    auto c = parse_finite_double("captured", q["captured"]);
    if (!c || *c < 0) return refuse(400, "captured: must be a finite number of Unix seconds");
    captured = *c;
  }
  const std::string type = media_type(req.get_header_value("Content-Type"));
  if (type != "model/gltf-binary")
    return refuse(415, "Content-Type must be model/gltf-binary (a keyframe GLB); got '" + type.substr(0, 60) + "'");
  if (!uploads_.try_acquire()) {
    GatedServer::close_after_response();
    res.set_header("Retry-After", "1");
    return send_error(res, 503, "too many uploads at once; retry later");
  }
  SlotRelease release{&uploads_};
  std::vector<std::uint8_t> glb;
  if (auto refused = read_whole_body(reader, options_.max_body_bytes, &glb)) return send_refusal(res, *refused);
  auto decoded = decode_client_glb(glb);
  if (!decoded) return send_error(res, decoded.error());
  const size_t triangles = decoded->triangle_count();
  auto placed = place_keyframe(std::move(*decoded), *seq, *pose);
  if (!placed) return send_error(res, placed.error());

  MissionKeyframe k;
  k.mission = *name;
  k.seq = *seq;
  k.rev = rev;
  k.pose = *pose;
  k.triangles = triangles;
  k.captured = captured;
  k.received = received;
  k.camera = mission_camera_json(placed->cameras.front());
  std::lock_guard lock(post_mutex_);
  const auto t_store = std::chrono::steady_clock::now();
  auto put = missions_.put(k, glb);
  if (!put) return send_error(res, put.error());
  if (put->outcome == PutOutcome::kConflict) {
    nlohmann::json body = nlohmann::json::parse(error_body(
        409, "keyframe " + std::to_string(*seq) + " of mission " + *name + " is stored with another body or pose"));
    body["error"] = "conflict";
    body["stored"] = put->keyframe.answer();
    return send_json(res, 409, body);
  }
  if (put->outcome == PutOutcome::kStale) {
    nlohmann::json body = nlohmann::json::parse(
        error_body(409, "keyframe " + std::to_string(*seq) + " of mission " + *name + " is stored at revision " +
                            std::to_string(put->keyframe.rev) + ", newer than " + std::to_string(rev)));
    body["error"] = "stale_revision";
    body["stored"] = put->keyframe.answer();
    return send_json(res, 409, body);
  }
  res.set_header("Location", "/v1/missions/" + *name);
  if (put->outcome == PutOutcome::kSame) return send_json(res, 200, put->keyframe.answer());
  // Stored: views draw it at once (a keyframe the tileset does not hold yet is drawn whole, service/mission_view.h),
  // and the tile worker takes it into the tileset off this request's path.
  const auto t_done = std::chrono::steady_clock::now();
  res.set_header("X-Store-Ms", std::to_string(ms_between(t_store, t_done)));
  const double available = unix_seconds_now();
  auto marked = missions_.mark_available(*name, *seq, available);
  if (!marked) return send_error(res, marked.error());
  tiles_.enqueue(*name);
  k = put->keyframe;
  k.available = available;
  if (k.first_available <= 0) k.first_available = available;  // a first revision (a revision keeps the seq's first)
  send_json(res, 201, k.answer());
}

void MissionRoutes::get_mission(const httplib::Request& req, httplib::Response& res) {
  auto name = name_or_error(req, res);
  if (!name) return;
  auto page = parse_keyframe_page(req.params);
  if (!page) return send_error(res, page.error());
  auto keyframes = missions_.keyframes(*name);
  if (!keyframes) return send_error(res, 404, "no mission " + *name);
  // Totals over every keyframe; entries only for the page (keyframes are in seq order).
  std::uint64_t bytes = 0, triangles = 0;
  for (const auto& k : *keyframes) {
    bytes += k.bytes;
    triangles += k.triangles;
  }
  nlohmann::json list = nlohmann::json::array();
  auto it = std::upper_bound(keyframes->begin(), keyframes->end(), page->after,
                             [](std::int64_t after, const MissionKeyframe& k) { return after < k.seq; });
  for (; it != keyframes->end() && list.size() < page->limit; ++it) {
    nlohmann::json e = it->entry();
    // The keyframe's own intrinsics (its capture camera): the operator page projects its overlay with them.
    if (it->camera.is_object()) {
      nlohmann::json intrinsics = nlohmann::json::object();
      for (const char* key : {"fx", "fy", "cx", "cy", "width", "height"})
        if (it->camera.contains(key)) intrinsics[key] = it->camera[key];
      e["intrinsics"] = intrinsics;
    }
    list.push_back(std::move(e));
  }
  nlohmann::json next = nullptr;
  if (it != keyframes->end() && !list.empty()) next = list.back()["seq"];
  send_json(res, 200,
            {{"name", *name},
             {"keyframe_count", keyframes->size()},
             {"bytes", bytes},
             {"triangles", triangles},
             {"after", page->after < 0 ? nlohmann::json(nullptr) : nlohmann::json(page->after)},
             {"limit", page->limit},
             {"keyframes", list},
             {"next_after", next}});
}

void MissionRoutes::get_model(const httplib::Request& req, httplib::Response& res) {
  auto name = name_or_error(req, res);
  if (!name) return;
  // ?flavor=compact|compat|draco as for scenes (service/model_flavors.h); none: compact, as before.
  std::optional<ModelFlavor> asked;
  if (!read_flavor_param(req, res, &asked)) return;
  std::optional<double> max_error_m;
  if (!read_max_error_param(req, res, &max_error_m)) return;
  for (const auto& [k, v] : req.params)
    if (k != "flavor" && k != "max-error")
      return send_error(res, 400, "unknown parameter " + quote_for_error(k) + " (flavor, max-error)");
  const ModelFlavor flavor = asked.value_or(ModelFlavor::kCompact);
  auto keyframes = missions_.keyframes(*name);
  if (!keyframes) return send_error(res, 404, "no mission " + *name);
  // max-error: the tiles as stored (compact), merged and streamed from disk (service/mission_export.h).
  if (max_error_m) {
    if (flavor != ModelFlavor::kCompact)
      return send_error(res, 400, "max-error exports are compact only (the tiles are stored so); drop flavor=");
    return send_tile_model(req, res, tiles_, *name, *max_error_m);
  }
  if (keyframes->size() > options_.max_model_keyframes)
    return send_error(res, 409,
                      "model.glb without max-error assembles every keyframe in memory, and this mission has " +
                          std::to_string(keyframes->size()) +
                          " (serve --max-model-keyframes: " + std::to_string(options_.max_model_keyframes) +
                          "); ask for ?max-error=0 (full detail from the tiles, streamed from disk) or ?max-error=M "
                          "(metres, coarser)");
  std::string made_of;
  for (const auto& k : *keyframes) made_of += std::to_string(k.seq) + ":" + k.etag + " ";
  const std::string cache_key = *name + "?" + to_string(flavor);
  CachedModel model;
  {
    std::lock_guard lock(model_mutex_);
    auto it = models_.find(cache_key);
    if (it != models_.end() && it->second.made_of == made_of) model = it->second;
  }
  res.set_header("X-Model-Cache", model.glb ? "hit" : "miss");
  if (!model.glb) {
    auto scene = assemble_mission(missions_, *name);
    if (!scene) return send_error(res, scene.error());
    auto glb = encode_glb(*scene, flavor_write_options(flavor));
    if (!glb) return send_error(res, glb.error());
    model.made_of = made_of;
    model.etag = etag_of(glb->data(), glb->size());
    model.glb = std::make_shared<const std::vector<std::uint8_t>>(std::move(*glb));
    std::lock_guard lock(model_mutex_);
    models_[cache_key] = model;  // a mission deleted meanwhile leaves one stale entry, replaced or never matched
  }
  send_model(req, res, model.glb, model.etag, asked ? *name + "-" + to_string(flavor) + ".glb" : *name + ".glb");
}

void MissionRoutes::get_view(const httplib::Request& req, httplib::Response& res) {
  auto name = name_or_error(req, res);
  if (!name) return;
  auto keyframes = missions_.keyframes(*name);
  if (!keyframes) return send_error(res, 404, "no mission " + *name);
  // pose=capture (the newest keyframe's camera) and pose=keyframe:N (that keyframe's) become a full camera; the rest
  // is the scene view's query, parsed by its own parser.
  QueryParams params = req.params;
  if (req.method == "POST") params.emplace("camera", req.body);
  std::optional<std::int64_t> keyframe_pose;
  bool capture = false;
  if (params.count("pose") == 1) {
    auto it = params.find("pose");
    if (it->second.rfind("keyframe:", 0) == 0) {
      keyframe_pose = parse_seq(it->second.substr(9));
      if (!keyframe_pose) return send_error(res, 400, "pose: keyframe:N needs a seq 0..2^31-1");
      it->second = "capture";
    }
    capture = it->second == "capture";
  }
  // max-error=PX: the screen-space error the tiles may show (service/mission_view.h); the rest is the scene view's.
  // Given, it is kept; by default it is coarsened until the view fits a renderer's share of the resident cap.
  double max_error_px = kDefaultMaxErrorPx;
  size_t fit_bytes = pool_.part_cap_bytes();
  if (auto it = params.find("max-error"); it != params.end()) {
    if (params.count("max-error") > 1) return send_error(res, 400, "max-error: given more than once");
    auto v = parse_finite_double("max-error", it->second);
    if (!v) return send_error(res, v.error());
    if (*v < 0.0 || *v > kMaxMaxErrorPx)
      return send_error(res, 400, "max-error: pixels of screen-space error, 0 (full detail) .. 1000");
    max_error_px = *v;
    fit_bytes = 0;
    params.erase(it);
  }
  auto request = parse_view_request(params);
  if (!request) return send_error(res, request.error());
  if (capture) {
    // The robot's camera now: the keyframe captured last (a sender that sends older keyframes after an outage gives
    // them higher seqs), the higher seq on a tie.
    const MissionKeyframe* k = nullptr;
    for (const auto& kf : *keyframes)
      if (!k || kf.captured >= k->captured) k = &kf;
    if (keyframe_pose) {
      k = nullptr;
      for (const auto& kf : *keyframes)
        if (kf.seq == *keyframe_pose) k = &kf;
      if (!k) return send_error(res, 404, "no keyframe " + std::to_string(*keyframe_pose) + " in mission " + *name);
    }
    if (!k) return send_error(res, 404, "mission " + *name + " has no keyframe");
    auto camera = mission_view_camera(*k, request->width, request->height);
    if (!camera) return send_error(res, camera.error());
    request->full_camera = true;
    request->capture_pose = false;
    request->camera = *camera;
  }
  // The default pose is the first keyframe's camera, as for a scene's first capture camera.
  if (!request->full_camera && request->capture_pose) {
    if (keyframes->empty()) return send_error(res, 404, "mission " + *name + " has no keyframe");
    auto first = std::min_element(keyframes->begin(), keyframes->end(),
                                  [](const auto& a, const auto& b) { return a.seq < b.seq; });
    auto camera = mission_view_camera(*first, request->width, request->height);
    if (!camera) return send_error(res, camera.error());
    request->full_camera = true;
    request->camera = *camera;
  }
  auto camera = make_view_camera(*request, {});
  if (!camera) return send_error(res, camera.error());
  auto plan = std::make_shared<MissionViewPlan>(
      plan_mission_view(missions_, tiles_, *name, *keyframes, *camera, max_error_px, fit_bytes));
  res.set_header("X-Tileset-Version", std::to_string(plan->tileset_version));
  res.set_header("X-Tiles", std::to_string(plan->tiles));
  res.set_header("X-Max-Error", nlohmann::json(plan->max_error_px).dump());
  res.set_header("X-Pending-Keyframes", std::to_string(plan->pending));
  res.set_header("X-Stale-Tiles", std::to_string(plan->stale_tiles));
  if (plan->pending_left_out > 0) res.set_header("X-Pending-Left-Out", std::to_string(plan->pending_left_out));
  render_view_(
      req, *request,
      [this, plan, request = *request] { return pool_.render_parts(std::move(plan->parts), plan->camera, request); },
      res);
}

void MissionRoutes::get_events(const httplib::Request& req, httplib::Response& res) {
  auto name = name_or_error(req, res);
  if (!name) return;
  std::optional<MissionEventId> last;
  std::string last_text = req.get_header_value("Last-Event-ID");
  if (last_text.empty() && req.has_param("last_event_id")) last_text = req.get_param_value("last_event_id");
  if (!last_text.empty()) {
    last = parse_event_id(last_text);
    if (!last) return send_error(res, 400, "Last-Event-ID: must be an event id, <seq> or <seq>-<rev>");
  }
  for (const auto& [k, v] : req.params)
    if (k != "last_event_id") return send_error(res, 400, "unknown parameter '" + k.substr(0, 40) + "'");
  auto cursor = missions_.cursor_after(*name, last);
  if (!cursor) return send_error(res, 404, "no mission " + *name);
  if (!streams_.try_acquire()) {
    res.set_header("Retry-After", "5");
    return send_error(res, 503,
                      "too many event streams open (" + std::to_string(options_.max_event_streams) +
                          ", --max-event-streams); retry later");
  }
  struct Stream {
    std::string name;
    EventCursor cursor;
    std::chrono::steady_clock::time_point ends;
    bool first = true;
    std::atomic<bool> released{false};
  };
  auto stream = std::make_shared<Stream>();
  stream->name = *name;
  stream->cursor = *cursor;
  stream->ends = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                        std::chrono::duration<double>(options_.event_stream_max_s));
  res.set_header("Cache-Control", "no-store");
  res.set_header("X-Accel-Buffering", "no");  // a proxy in front (nginx) must not buffer the stream
  // The stream's slot goes back when the stream decides to end, before its last chunk is sent: a client that sees
  // the end and reconnects at once finds it free (the releaser below runs only after the response is complete).
  auto release = [this, stream] {
    if (!stream->released.exchange(true)) streams_.release();
  };
  res.set_chunked_content_provider(
      "text/event-stream",
      [this, stream, release](size_t, httplib::DataSink& sink) {
        std::string out;
        if (stream->first) {
          out = "retry: 1000\n\n";  // EventSource waits 1 s before it reconnects
          stream->first = false;
        }
        const auto now = std::chrono::steady_clock::now();
        if (stopping_ || now >= stream->ends) {
          release();
          sink.done();
          return true;
        }
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(stream->ends - now);
        const auto keep_alive = std::chrono::milliseconds(static_cast<long long>(options_.keep_alive_s * 1000));
        // Backlog first (no wait), then wait for the next keyframe.
        EventBatch batch = missions_.wait_events(
            stream->name, stream->cursor, out.empty() ? std::min(left, keep_alive) : std::chrono::milliseconds(0));
        if (!batch.exists) {
          if (!out.empty()) sink.write(out.data(), out.size());
          release();
          sink.done();  // the mission was deleted
          return true;
        }
        for (const auto& k : batch.events) out += event_text(k);
        if (batch.tileset_version) out += tileset_event_text(*batch.tileset_version, tiles_.snapshot(stream->name));
        if (out.empty() && std::chrono::steady_clock::now() < stream->ends && !stopping_) out = ": keep-alive\n\n";
        if (!out.empty() && !sink.write(out.data(), out.size())) return false;
        return true;
      },
      [release](bool) { release(); });
}

void MissionRoutes::delete_mission(const httplib::Request& req, httplib::Response& res) {
  auto name = name_or_error(req, res);
  if (!name) return;
  std::lock_guard lock(post_mutex_);
  auto st = missions_.remove(*name);
  if (!st) return send_error(res, st.error());
  pool_.forget(mission_scene_key(*name));
  tiles_.forget(*name);
  {
    std::lock_guard tileset_lock(tileset_mutex_);
    gzipped_tilesets_.erase(*name);
  }
  res.status = 204;
}

void MissionRoutes::get_tileset(const httplib::Request& req, httplib::Response& res) {
  auto name = name_or_error(req, res);
  if (!name) return;
  if (!req.params.empty()) return send_error(res, 400, "tileset.json takes no parameters");
  if (!missions_.keyframes(*name)) return send_error(res, 404, "no mission " + *name);
  auto snapshot = tiles_.snapshot(*name);
  const std::uint64_t version = snapshot ? snapshot->version : 0;
  // Gzipped for clients that accept it, as is for the others; either way sent as made (http_gzip.h). Each
  // representation has its own strong ETag.
  const bool gzipped = snapshot && accepts_gzip(req);
  const std::string etag = "\"tileset-" + std::to_string(version) + (gzipped ? "-gzip" : "") + "\"";
  res.set_header("Cache-Control", "no-cache");
  res.set_header("Vary", "Accept-Encoding");
  if (answer_not_modified(req, res, etag)) return;
  res.status = 200;
  // Before the first update commits, an empty tileset of version 0: a client polls or waits for the "tileset" event.
  if (!snapshot)
    return send_shared(res, std::make_shared<const std::string>(tiles::make_tileset({}, 1, 0, "tiles/").dump()),
                       "application/json");
  if (!gzipped)
    return send_shared(res, std::shared_ptr<const std::string>(snapshot, &snapshot->tileset_json), "application/json");
  std::shared_ptr<const std::string> bytes;
  {
    std::lock_guard lock(tileset_mutex_);
    auto it = gzipped_tilesets_.find(*name);
    if (it != gzipped_tilesets_.end() && it->second.of.lock() == snapshot) bytes = it->second.bytes;
  }
  if (!bytes) {
    // zlib's default level: this runs on a request's path, once per version.
    bytes = std::make_shared<const std::string>(gzip(snapshot->tileset_json, 6));
    if (bytes->empty()) return send_error(res, 500, "tileset.json could not be compressed");
    std::lock_guard lock(tileset_mutex_);
    gzipped_tilesets_[*name] = {snapshot, bytes};
  }
  res.set_header("Content-Encoding", "gzip");
  send_shared(res, std::move(bytes), "application/json");
}

void MissionRoutes::get_tile(const httplib::Request& req, httplib::Response& res) {
  auto name = name_or_error(req, res);
  if (!name) return;
  const std::string file = req.matches.size() > 2 ? req.matches[2].str() : std::string();
  if (!is_tile_file_name(file))
    return send_error(res, 400,
                      "malformed tile name (expected <level>_<x>_<z>.v<version>.glb, as tileset.json names it)");
  if (!req.params.empty()) return send_error(res, 400, "a tile takes no parameters");
  auto snapshot = tiles_.snapshot(*name);
  if (!snapshot || !snapshot->files.count(file))
    return send_error(res, 404, "no tile " + file + " in mission " + *name + " (tiles of older versions are removed)");
  const std::string etag = "\"" + file + "\"";  // the name changes with the content: a strong validator
  res.set_header("Cache-Control", "public, max-age=31536000, immutable");
  if (answer_not_modified(req, res, etag)) return;
  auto bytes = std::make_shared<std::string>();
  {
    auto path = tiles_.tile_file(*name, file);
    std::ifstream in;
    if (path) in.open(*path, std::ios::binary);
    if (!in) return send_error(res, 404, "no tile " + file + " in mission " + *name + " (removed meanwhile)");
    bytes->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  res.status = 200;
  res.set_content(std::move(*bytes), "model/gltf-binary");
}

}  // namespace rgbdcast::service
