#include "service/view_service.h"

#include <unistd.h>

#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <future>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "base/malloc_settings.h"
#include "base/stopwatch.h"
#include "gltf/gltf_io.h"
#include "renderer/create_renderer.h"
#include "service/connection_gate.h"
#include "service/http_errors.h"
#include "service/http_reply.h"
#include "service/image_encode.h"
#include "service/job_queue.h"
#include "service/metrics.h"
#include "service/mission_routes.h"
#include "service/mission_scene.h"
#include "service/mission_store.h"
#include "service/mission_tiles.h"
#include "service/model_flavors.h"
#include "service/render_pool.h"
#include "service/request_guard.h"
#include "service/routes.h"
#include "service/scene_ingest.h"
#include "service/scene_store.h"
#include "service/store_open.h"
#include "service/view_params.h"
#include "service/web_assets.h"

namespace rgbdcast::service {
namespace {

using Clock = std::chrono::steady_clock;

// Set by the pre-routing handler, read by the logger: both run on the thread that serves the request.
thread_local Clock::time_point t_request_start{};
thread_local const char* t_route = "other";

std::string fmt_ms(double ms) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f", ms);
  return buf;
}

nlohmann::json scene_summary(const StoredScene& s) {
  nlohmann::json j = {{"id", s.id}, {"bytes", s.bytes}, {"created_unix_s", s.created_unix_s}};
  if (s.points) j["points"] = *s.points;
  if (s.triangles) j["triangles"] = *s.triangles;
  if (s.vertices) j["vertices"] = *s.vertices;
  if (s.source) j["source"] = *s.source;
  j["links"] = {{"self", "/v1/scenes/" + s.id},
                {"model", "/v1/scenes/" + s.id + "/model.glb"},
                {"view", "/v1/scenes/" + s.id + "/view?pose=capture"}};
  return j;
}

// Returns freed heap to the system once no reduction is running: a frame reduction peaks at hundreds of MB.
void trim_heap() { return_freed_heap(); }

// OpenMP threads per frame reduction: the operator's number, else the cores shared among the reducers.
int reduce_threads(const ServeOptions& o) {
  if (o.reduce_threads > 0) return o.reduce_threads;
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  return static_cast<int>(std::max(1u, cores / static_cast<unsigned>(std::max(1, o.reducers))));
}

}  // namespace

struct ViewService::Impl {
  ServeOptions options;
  std::string replica;                                                          // the name sent as X-Rgbdcast-Replica
  std::string store_kind;                                                       // "directory" or "postgresql"
  std::function<void(std::function<void(const std::string&)>)> follow_changes;  // OpenedStores::follow_changes
  TileStorageFactory tile_storage;                                              // OpenedStores::tile_storage
  std::atomic<bool> draining{false};
  std::unique_ptr<SceneStore> store;
  std::unique_ptr<RenderPool> pool;
  std::unique_ptr<JobQueue> reducers;
  std::string backend_reason;
  std::mutex reason_mutex;
  Metrics metrics;
  ModelFlavors flavors;
  GuardConfig guard;
  std::unique_ptr<Slots> uploads;
  std::unique_ptr<MissionStore> missions;
  std::unique_ptr<MissionTiles> tiles;  // after missions: its worker reads the store until it is destroyed
  std::unique_ptr<MissionRoutes> mission_routes;
  std::unique_ptr<WebAssets> web;
  std::unique_ptr<GatedServer> server;  // last: destroyed first, its workers may still wait on the pools
  int port = 0;

  void routes();
  // Runs a handler: nothing escapes it, whatever it throws.
  template <class F>
  static void run_guarded(httplib::Response& res, F&& call) {
    try {
      call();
    } catch (const std::exception& e) {
      send_error(res, 500, redact_paths(std::string("unexpected failure: ") + e.what()));
    } catch (...) {
      send_error(res, 500, "unexpected failure");
    }
  }
  static httplib::Server::Handler guarded(std::function<void(const httplib::Request&, httplib::Response&)> f) {
    return [f = std::move(f)](const httplib::Request& req, httplib::Response& res) {
      run_guarded(res, [&] { f(req, res); });
    };
  }
  using ReaderHandler = std::function<void(const httplib::Request&, httplib::Response&, const httplib::ContentReader&)>;
  static httplib::Server::HandlerWithContentReader guarded_reader(ReaderHandler f) {
    return [f = std::move(f)](const httplib::Request& req, httplib::Response& res, const httplib::ContentReader& r) {
      run_guarded(res, [&] { f(req, res, r); });
    };
  }
  // The scene named by the first capture of the route, or an error response (400 malformed id, 404 unknown).
  std::optional<StoredScene> scene_or_error(const httplib::Request& req, httplib::Response& res) {
    const std::string id = req.matches.size() > 1 ? req.matches[1].str() : std::string();
    if (!is_valid_scene_id(id)) {
      send_error(res, 400, "malformed scene id (expected 32 lowercase hex digits)");
      return std::nullopt;
    }
    auto s = store->get(id);
    if (!s) send_error(res, 404, "no scene " + id);
    return s;
  }
  httplib::Server::HandlerResponse pre_route(const httplib::Request& req, httplib::Response& res);
  void get_readyz(httplib::Response& res);
  void post_scene(const httplib::Request& req, httplib::Response& res, const httplib::ContentReader& reader);
  Result<IngestedScene> reduce_frame_upload(FrameUpload upload, httplib::Response& res, bool* busy);
  void get_view(const httplib::Request& req, httplib::Response& res);
  // Runs `render` (a pool render of the parsed view) and answers its image.
  void render_and_send(const httplib::Request& req, const ViewRequest& request,
                       const std::function<Result<RenderOutput>()>& render, httplib::Response& res);
  void get_glb(const httplib::Request& req, httplib::Response& res);
};

httplib::Server::HandlerResponse ViewService::Impl::pre_route(const httplib::Request& req, httplib::Response& res) {
  t_request_start = Clock::now();
  t_route = match_route(req.path).label;
  RequestHead head;
  head.method = req.method;
  head.path = req.path;
  head.headers.assign(req.headers.begin(), req.headers.end());
  auto refusal = check_request(head, guard);
  if (!refusal) return httplib::Server::HandlerResponse::Unhandled;
  if (!refusal->allow.empty()) res.set_header("Allow", refusal->allow);
  if (refusal->www_authenticate) res.set_header("WWW-Authenticate", "Bearer");
  res.set_header("Connection", "close");  // whatever body was sent is not read
  send_error(res, refusal->status, refusal->detail);
  GatedServer::close_after_response();
  return httplib::Server::HandlerResponse::Handled;
}

Result<IngestedScene> ViewService::Impl::reduce_frame_upload(FrameUpload upload, httplib::Response& res, bool* busy) {
  auto promise = std::make_shared<std::promise<Result<IngestedScene>>>();
  auto done = promise->get_future();
  const bool queued = reducers->try_submit([this, promise, up = std::move(upload)] {
    Result<IngestedScene> r = make_error(ErrorCode::kInternal, "reduction failed");
    try {
      r = ingest_frame(up);
    } catch (const std::exception& e) {
      r = make_error(ErrorCode::kInternal, std::string("reduction threw: ") + e.what());
    }
    promise->set_value(std::move(r));
    if (reducers->waiting() == 0) trim_heap();
  });
  if (!queued) {
    *busy = true;
    send_busy(res,
              "reduction queue full (" + std::to_string(options.reducers + options.reduce_queue) +
                  " frames in progress); retry later",
              5);
    return make_error(ErrorCode::kUnavailable, "busy");
  }
  try {
    return done.get();
  } catch (const std::future_error&) {
    return make_error(ErrorCode::kUnavailable, "server is stopping");
  }
}

void ViewService::Impl::post_scene(const httplib::Request& req, httplib::Response& res,
                                   const httplib::ContentReader& reader) {
  if (!uploads->try_acquire()) {
    GatedServer::close_after_response();
    return send_busy(res, "too many uploads at once (" + std::to_string(options.max_uploads) + "); retry later", 1);
  }
  struct Release {
    Slots* s;
    ~Release() { s->release(); }
  } release{uploads.get()};

  const std::string type = media_type(req.get_header_value("Content-Type"));
  const bool multipart = req.is_multipart_form_data();
  if (type != "model/gltf-binary" && !multipart) {
    GatedServer::close_after_response();
    return send_error(res, 415,
                      "Content-Type must be model/gltf-binary (a GLB) or multipart/form-data (color, "
                      "depth, intrinsics); got '" +
                          type.substr(0, 60) + "'");
  }
  std::vector<std::uint8_t> glb;
  FrameParts parts;
  if (auto refused = multipart ? read_frame_parts(reader, options.max_body_bytes, &parts)
                               : read_whole_body(reader, options.max_body_bytes, &glb))
    return send_refusal(res, *refused);

  Result<IngestedScene> ingested = make_error(ErrorCode::kInternal, "unreachable");
  if (!multipart) {
    ingested = ingest_glb(std::move(glb));
  } else {
    FrameUpload up;
    // Optional form fields: the preset (realtime, the default, or paper) and the realtime budget in kB.
    if (parts.preset) {
      auto preset = parse_preset(*parts.preset);
      if (!preset) return send_error(res, 400, "multipart part 'preset': " + preset.error().message);
      up.preset = *preset;
    }
    if (parts.budget_kb) {
      char* end = nullptr;
      const std::string& text = *parts.budget_kb;
      const double kb = std::strtod(text.c_str(), &end);
      if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(kb) || kb < 0)
        return send_error(res, 400, "multipart part 'budget_kb' must be a number of kB, 0 (none) or more");
      if (up.preset != Preset::kRealtime && kb > 0)
        return send_error(res, 400, "multipart part 'budget_kb' needs the realtime preset");
      up.budget_kb = kb;
    }
    up.color = std::move(parts.color);
    up.depth = std::move(parts.depth);
    up.intrinsics_json = std::move(parts.intrinsics_json);
    up.scratch_dir = options.data_dir + "/scenes";
    up.max_width = options.max_frame_width;
    up.max_height = options.max_frame_height;
    up.threads = reduce_threads(options);
    bool busy = false;
    ingested = reduce_frame_upload(std::move(up), res, &busy);
    if (busy) return;
  }
  if (!ingested) return send_error(res, ingested.error());
  auto stored = store->put(ingested->glb, ingested->stats);
  if (!stored) return send_error(res, stored.error());
  res.set_header("Location", "/v1/scenes/" + stored->id);
  send_json(res, 201, stored->metadata());
}

void ViewService::Impl::get_view(const httplib::Request& req, httplib::Response& res) {
  auto scene = scene_or_error(req, res);
  if (!scene) return;
  QueryParams params = req.params;
  if (req.method == "POST") params.emplace("camera", req.body);  // the camera JSON as the body (camera_json.h)
  auto request = parse_view_request(params);
  if (!request) return send_error(res, request.error());
  render_and_send(
      req, *request, [&] { return pool->render(scene->id, *request); }, res);
}

void ViewService::Impl::render_and_send(const httplib::Request& req, const ViewRequest& view,
                                        const std::function<Result<RenderOutput>()>& render, httplib::Response& res) {
  const ViewRequest* request = &view;
  if (req.method == "HEAD") {  // what a GET would answer, without rendering
    res.status = 200;
    res.set_header("Cache-Control", "no-store");
    res.set_header("Content-Type", mime_type(request->format));
    return;
  }
  auto out = render();
  if (!out) return send_error(res, out.error());
  const auto t0 = Clock::now();
  auto encoded = encode_image(out->color, request->format, request->quality);
  if (!encoded) return send_error(res, encoded.error());
  const double encode_ms = ms_since(t0);
  metrics.observe_render(to_string(request->mode), out->backend, out->render_ms / 1000.0);
  res.set_header("X-Render-Ms", fmt_ms(out->render_ms));
  res.set_header("X-Readback-Ms", fmt_ms(out->readback_ms));
  res.set_header("X-Encode-Ms", fmt_ms(encode_ms));
  res.set_header("X-Queue-Ms", fmt_ms(out->queue_ms));
  if (out->upload_ms > 0 || out->load_ms > 0) res.set_header("X-Upload-Ms", fmt_ms(out->load_ms + out->upload_ms));
  res.set_header("X-Backend", out->backend);
  if (out->parts_drawn + out->parts_loaded + out->parts_missing > 0) {  // a tiled view (service/mission_view.h)
    res.set_header("X-Parts-Drawn", std::to_string(out->parts_drawn));
    res.set_header("X-Parts-Loaded", std::to_string(out->parts_loaded));
    res.set_header("X-Render-Batches", std::to_string(out->batches));
    if (out->parts_missing > 0) res.set_header("X-Parts-Missing", std::to_string(out->parts_missing));
  }
  res.set_header("Cache-Control", "no-store");
  res.status = 200;
  res.body.assign(encoded->begin(), encoded->end());
  res.set_header("Content-Type", mime_type(request->format));
}

void ViewService::Impl::get_glb(const httplib::Request& req, httplib::Response& res) {
  auto scene = scene_or_error(req, res);
  if (!scene || flavors.serve(req, res, *scene, *store)) return;  // ?flavor=: service/model_flavors.h
  res.set_header("ETag", scene->etag);
  res.set_header("Cache-Control", "no-cache");
  const std::string inm = req.get_header_value("If-None-Match");
  if (!inm.empty() && (inm == "*" || inm.find(scene->etag) != std::string::npos)) {
    res.status = 304;
    return;
  }
  auto bytes = store->read_glb(scene->id);
  if (!bytes) return send_error(res, bytes.error());
  res.status = 200;
  res.body.assign(bytes->begin(), bytes->end());
  res.set_header("Content-Type", "model/gltf-binary");
  res.set_header("Content-Disposition", "attachment; filename=\"" + scene->id + ".glb\"");
}

void ViewService::Impl::get_readyz(httplib::Response& res) {
  nlohmann::json checks = nlohmann::json::object();
  bool ready = true;
  auto check = [&](const char* name, const Status& st) {
    checks[name] = st ? "ok" : st.error().message;
    ready = ready && static_cast<bool>(st);
  };
  check("scenes", store->ping());
  check("missions", missions->ping());
  check("renderer", pool->backend().empty() ? make_error(ErrorCode::kUnavailable, "no renderer") : ok_status());
  check("draining", draining ? make_error(ErrorCode::kUnavailable, "stopping: no new work") : ok_status());
  send_json(
      res, ready ? 200 : 503,
      {{"status", ready ? "ready" : "not ready"}, {"replica", replica}, {"store", store_kind}, {"checks", checks}});
}

void ViewService::Impl::routes() {
  server->set_payload_max_length(options.max_body_bytes);
  server->set_default_headers({{"X-Rgbdcast-Replica", replica}});
  server->set_pre_routing_handler(
      [this](const httplib::Request& req, httplib::Response& res) { return pre_route(req, res); });
  // Called for every response >= 400, ours included: only fills a body when there is none (404 of an unknown
  // route, 400 of a request the library could not parse).
  const size_t limit_bytes = options.max_body_bytes;
  server->set_error_handler([limit_bytes](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;
    // An error of the HTTP layer may leave unread bytes (a request line it refused leaves its headers): close.
    GatedServer::close_after_response();
    res.set_header("Connection", "close");
    static const std::set<std::string> kParsed = {"GET",     "HEAD",    "POST",  "PUT",   "DELETE",
                                                  "CONNECT", "OPTIONS", "TRACE", "PATCH", "PRI"};
    if (res.status == 400 && req.path.empty() && !req.method.empty() && !kParsed.count(req.method)) {
      // httplib refuses methods it does not know before routing; on a known route that is a 405.
      const RouteMatch route = match_route(req.target.substr(0, req.target.find('?')));
      if (route.known) {
        res.status = 405;
        res.set_header("Allow", route.allow);
        res.set_content(error_body(405, "method " + req.method.substr(0, 20) + " not allowed on " + route.label),
                        "application/json");
        return;
      }
    }
    std::string detail;
    // A body that stopped arriving (an outage, or under the minimum rate): httplib's 400 becomes a 408, which a
    // client retries (rgbdcast stream's sender gives any other 4xx up for good).
    if (res.status == 400 && GatedServer::request_read_failed()) res.status = 408;
    switch (res.status) {
      case 408:
        detail = "request body not received in time";
        break;
      case 404:
        detail = "no route " + req.method.substr(0, 20) + " " + req.path.substr(0, 200);
        break;
      case 413:
        detail = "request body over the limit of " + std::to_string(limit_bytes) + " bytes (--max-body-mib)";
        break;
      case 414:
        detail = "request line over the limit of 8192 bytes";
        break;
      default:
        detail = "request rejected by the HTTP layer";
        break;
    }
    res.set_content(error_body(res.status, detail), "application/json");
  });
  server->set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "unexpected failure";
    try {
      if (ep) std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what += std::string(": ") + e.what();
    } catch (...) {}
    send_error(res, 500, redact_paths(what));
  });
  server->set_logger([this](const httplib::Request& req, const httplib::Response& res) {
    double seconds = 0.0;
    if (t_request_start != Clock::time_point{})
      seconds = std::chrono::duration<double>(Clock::now() - t_request_start).count();
    t_request_start = Clock::time_point{};
    metrics.observe_request(req.method, t_route, res.status, seconds);
    t_route = "other";
  });

  using Req = const httplib::Request&;
  using Res = httplib::Response&;
  server->Get("/", guarded([](Req, Res res) { res.set_content(operator_page_html(), "text/html; charset=utf-8"); }));
  // Liveness: the process answers. Readiness: its stores answer, its renderers are up, and it is not draining; a
  // balancer sends work only to a ready replica.
  server->Get("/livez", guarded([this](Req, Res res) {
                send_json(res, 200, {{"status", "alive"}, {"replica", replica}});
              }));
  server->Get("/readyz", guarded([this](Req, Res res) { get_readyz(res); }));
  server->Get("/healthz", guarded([this](Req, Res res) {
                send_json(res, 200,
                          {{"status", "ok"},
                           {"backend", pool->backend()},
                           {"device", pool->device()},
                           {"scenes", store->count()},
                           {"missions", missions->count()},
                           {"web_modules", web->modules_present()}});
              }));
  server->Get("/metrics", guarded([this](Req, Res res) {
                MetricsGauges g;
                g.scenes_stored = store->count();
                g.bytes_stored = store->total_bytes();
                g.render_queue_depth = pool->queue_depth();
                g.render_rejected = pool->rejected();
                g.missions_stored = missions->count();
                g.event_streams_open = static_cast<size_t>(mission_routes->open_streams());
                g.resident_part_bytes = pool->resident_part_bytes();
                g.resident_parts = pool->resident_parts();
                const MissionTilesStats t = tiles->stats();
                g.leaves_built = t.leaves_built;
                g.inner_built = t.inner_built;
                g.hierarchies_loaded = t.opened_committed;
                res.set_content(metrics.prometheus_text(g), "text/plain; version=0.0.4; charset=utf-8");
              }));
  server->Post("/v1/scenes", guarded_reader([this](Req req, Res res, const httplib::ContentReader& reader) {
                 post_scene(req, res, reader);
               }));
  server->Get("/v1/scenes", guarded([this](Req, Res res) {
                nlohmann::json body = {{"scenes", nlohmann::json::array()}};
                nlohmann::json& list = body["scenes"];
                store->for_each([&list](const StoredScene& s) { list.push_back(scene_summary(s)); });
                body["count"] = list.size();
                send_json(res, 200, body);
              }));
  server->Get(R"(/v1/scenes/([^/]+))", guarded([this](Req req, Res res) {
                auto s = scene_or_error(req, res);
                if (!s) return;
                nlohmann::json body = s->metadata();
                body["links"] = scene_summary(*s)["links"];
                send_json(res, 200, body);
              }));
  server->Delete(R"(/v1/scenes/([^/]+))", guarded([this](Req req, Res res) {
                   auto s = scene_or_error(req, res);
                   if (!s) return;
                   auto st = store->remove(s->id);
                   if (!st) return send_error(res, st.error());
                   pool->forget(s->id);
                   flavors.forget(s->id);
                   res.status = 204;
                 }));
  server->Get(R"(/v1/scenes/([^/]+)/model\.glb)", guarded([this](Req req, Res res) { get_glb(req, res); }));
  server->Get(R"(/v1/scenes/([^/]+)/view)", guarded([this](Req req, Res res) { get_view(req, res); }));
  server->Post(R"(/v1/scenes/([^/]+)/view)", guarded([this](Req req, Res res) { get_view(req, res); }));
  mission_routes->install(*server, guarded, guarded_reader);
  web->install(*server, guarded);
}

ViewService::ViewService(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ViewService::~ViewService() {
  if (impl_ && impl_->follow_changes) impl_->follow_changes(nullptr);  // first: changes name missions to the tiles
  if (impl_ && impl_->mission_routes) impl_->mission_routes->stop();
  if (impl_ && impl_->server) {
    impl_->server->stop();
    impl_->server->shut_down();
  }
}

namespace {

Status check_options(const ServeOptions& o) {
  auto bad = [](const std::string& m) { return make_error(ErrorCode::kInvalidArgument, m); };
  if (o.port < 0 || o.port > 65535) return bad("port must be 0..65535");
  if (o.threads < 1 || o.threads > 1024) return bad("threads must be 1..1024");
  if (o.max_body_bytes < 1024) return bad("body limit under 1 KiB");
  if (o.reduce_threads < 0 || o.reduce_threads > 256) return bad("reduce threads must be 0..256 (0: cores / reducers)");
  if (o.renderers < 1 || o.render_queue < 0 || o.reducers < 1 || o.reduce_queue < 0 || o.max_uploads < 1)
    return bad("renderers, reducers and max uploads must be at least 1, queues at least 0");
  // Views waiting for a renderer and bodies being received each hold an HTTP thread: with fewer threads than
  // they need, every thread blocks first and the queue's 503 never comes. Two stay for /healthz.
  // Open event streams hold a thread each for as long as they last (service/mission_routes.h).
  if (o.max_event_streams < 0 || o.max_event_streams > 256) return bad("max event streams must be 0..256");
  if (!(o.event_stream_max_s >= 1 && o.event_stream_max_s <= 86400)) return bad("event stream length 1..86400 s");
  if (!(o.keep_alive_s >= 0.1 && o.keep_alive_s <= 3600)) return bad("keep-alive interval 0.1..3600 s");
  const int needed = o.renderers + o.render_queue + o.max_uploads + o.max_event_streams + 2;
  if (o.threads < needed)
    return bad("--threads " + std::to_string(o.threads) + " is too few for --renderers + --render-queue + " +
               "--max-uploads + --max-event-streams + 2 = " + std::to_string(needed) +
               ": the queues could never answer 503");
  if (o.max_frame_width < 1 || o.max_frame_height < 1) return bad("frame limit must be positive");
  if (!(o.drain_s >= 0 && o.drain_s <= 3600)) return bad("drain time must be 0..3600 s");
  if (o.replica.size() > 64 ||
      o.replica.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789._-") !=
          std::string::npos)
    return bad("replica name must be up to 64 of A-Z a-z 0-9 . _ -");
  if (!is_loopback_address(o.bind) && o.token.empty() && !o.insecure_no_auth)
    return bad("binding to " + o.bind +
               " (not loopback) without --token-file would let anyone on the network "
               "upload and delete; give --token-file, or --insecure-no-auth to accept that");
  return ok_status();
}

// The default replica name: the host's (a container's is its id), cut to what a replica name may hold.
std::string host_name() {
  char buf[256] = {0};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "replica";
  std::string name;
  for (const char* p = buf; *p && name.size() < 64; ++p)
    if (std::isalnum(static_cast<unsigned char>(*p)) || *p == '.' || *p == '_' || *p == '-') name += *p;
  return name.empty() ? "replica" : name;
}

// Each renderer gets its share of the cores (llvmpipe and lavapipe otherwise start a thread per core each).
void cap_renderer_threads(int renderers) {
  if (std::getenv("LP_NUM_THREADS")) return;  // the operator's choice wins
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const unsigned each = std::max(1u, cores / static_cast<unsigned>(std::max(1, renderers)));
  ::setenv("LP_NUM_THREADS", std::to_string(each).c_str(), 0);
}

}  // namespace

Result<std::unique_ptr<ViewService>> ViewService::create(const ServeOptions& options) {
  auto st = check_options(options);
  if (!st) return st.error();
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  if (options.web_modules_dir.empty()) impl->options.web_modules_dir = RGBDCAST_WEB_MODULES_DIR;
  impl->web = std::make_unique<WebAssets>(impl->options.web_modules_dir);
  impl->replica = options.replica.empty() ? host_name() : options.replica;
  auto stores = open_stores(options.store, options.data_dir);
  if (!stores) return stores.error();
  impl->store = std::move(stores->scenes);
  impl->missions = std::move(stores->missions);
  impl->store_kind = stores->kind;
  impl->follow_changes = std::move(stores->follow_changes);
  impl->tile_storage = std::move(stores->tile_storage);
  for (const auto& q : impl->store->quarantined()) std::fprintf(stderr, "rgbdcast serve: warning: %s\n", q.c_str());
  for (const auto& q : impl->missions->quarantined()) std::fprintf(stderr, "rgbdcast serve: warning: %s\n", q.c_str());

  cap_renderer_threads(options.renderers);
  // The server's malloc profile (base/malloc_settings.h has the reasons); the environment's MALLOC_* win.
  apply_malloc_settings(server_malloc_settings());
  SceneStore* store_ptr = impl->store.get();
  std::string* reason = &impl->backend_reason;
  std::mutex* reason_mutex = &impl->reason_mutex;
  const BackendChoice choice = options.backend;
  RenderPoolOptions pool_options;
  pool_options.workers = options.renderers;
  pool_options.queue_capacity = options.render_queue;
  pool_options.resident_part_bytes = options.resident_mb << 20;
  auto pool = RenderPool::start(
      pool_options,
      [choice, reason, reason_mutex]() -> Result<std::unique_ptr<Renderer>> {
        auto sel = create_renderer(choice);
        if (!sel) return sel.error();
        std::lock_guard lock(*reason_mutex);
        *reason = sel->reason;
        return std::move(sel->renderer);
      },
      // Stored scenes; missions are drawn from parts (render_parts, service/mission_view.h), never whole.
      [store_ptr](const std::string& id) -> Result<std::shared_ptr<const Scene>> {
        auto bytes = store_ptr->read_glb(id);
        if (!bytes) return bytes.error();
        auto scene = decode_glb(bytes->data(), bytes->size());
        if (!scene)
          return make_error(ErrorCode::kInternal,
                            "stored scene " + id + " no longer decodes: " + scene.error().message);
        return std::shared_ptr<const Scene>(std::make_shared<Scene>(std::move(*scene)));
      });
  if (!pool) return pool.error();
  impl->pool = std::move(*pool);
  impl->reducers = std::make_unique<JobQueue>(options.reducers, options.reduce_queue);
  impl->uploads = std::make_unique<Slots>(options.max_uploads);
  MissionRouteOptions mission_options;
  mission_options.max_body_bytes = options.max_body_bytes;
  mission_options.max_event_streams = options.max_event_streams;
  mission_options.event_stream_max_s = options.event_stream_max_s;
  mission_options.keep_alive_s = options.keep_alive_s;
  mission_options.max_model_keyframes = static_cast<size_t>(options.max_model_keyframes);
  Impl* raw = impl.get();
  tiles::TilingOptions tiling;
  tiling.supersede = options.supersede;
  impl->tiles = std::make_unique<MissionTiles>(options.data_dir, *impl->missions, tiling, impl->tile_storage);
  impl->tiles->start();
  // Keyframes and removals made through other replicas (a shared store) bring this replica's tiles up to date too.
  MissionTiles* tiles = impl->tiles.get();
  MissionStore* mission_store = impl->missions.get();
  impl->follow_changes([tiles, mission_store](const std::string& name) {
    if (mission_store->keyframes(name))
      tiles->enqueue(name);
    else
      tiles->forget(name);
  });
  impl->mission_routes = std::make_unique<MissionRoutes>(
      mission_options, *impl->missions, *impl->tiles, *impl->pool, *impl->uploads,
      [raw](const httplib::Request& req, const ViewRequest& request,
            const std::function<Result<RenderOutput>()>& render,
            httplib::Response& res) { raw->render_and_send(req, request, render, res); });

  GateOptions gate;
  gate.workers = options.threads;
  gate.header_timeout_s = options.header_timeout_s;
  gate.idle_timeout_s = options.idle_timeout_s;
  gate.max_connections = options.max_connections;
  gate.response_header = "X-Rgbdcast-Replica: " + impl->replica;
  impl->server = std::make_unique<GatedServer>(gate);
  if (options.port == 0) {
    const int p = impl->server->bind_to_any_port(options.bind);
    if (p <= 0) return make_error(ErrorCode::kIo, "cannot bind " + options.bind + " (any port)");
    impl->port = p;
  } else {
    if (!impl->server->bind_to_port(options.bind, options.port))
      return make_error(ErrorCode::kIo, "cannot bind " + options.bind + ":" + std::to_string(options.port) +
                                            ": the port is in use (another server?) or the address is not one of "
                                            "this machine's");
    impl->port = options.port;
  }
  if (!impl->server->widen_backlog()) return make_error(ErrorCode::kIo, "cannot set the listen backlog");
  impl->guard =
      make_guard_config(options.bind, impl->port, options.allow_origins, options.token, options.max_body_bytes);
  impl->routes();
  return std::unique_ptr<ViewService>(new ViewService(std::move(impl)));
}

Result<nlohmann::json> ViewService::import_glb_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot read " + path);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  const std::string etag = etag_of(bytes.data(), bytes.size());
  for (const auto& s : impl_->store->list())
    if (s.etag == etag) return s.metadata();
  auto ingested = ingest_glb(std::move(bytes));
  if (!ingested) return make_error(ingested.error().code, path + ": " + ingested.error().message);
  auto stored = impl_->store->put(ingested->glb, ingested->stats);
  if (!stored) return stored.error();
  return stored->metadata();
}

int ViewService::port() const { return impl_->port; }
std::string ViewService::url() const {
  const std::string& b = impl_->options.bind;
  const bool v6 = b.find(':') != std::string::npos;
  return "http://" + (v6 ? "[" + b + "]" : b) + ":" + std::to_string(impl_->port);
}
std::string ViewService::backend() const { return impl_->pool->backend(); }
std::string ViewService::backend_reason() const { return impl_->backend_reason; }
std::string ViewService::device() const { return impl_->pool->device(); }
std::string ViewService::web_modules_dir() const { return impl_->options.web_modules_dir; }
bool ViewService::web_modules_present() const { return impl_->web->modules_present(); }
size_t ViewService::scene_count() const { return impl_->store->count(); }
const std::string& ViewService::replica() const { return impl_->replica; }

Status ViewService::run() {
  if (!impl_->server->listen_after_bind()) return make_error(ErrorCode::kIo, "the listener stopped with an error");
  return ok_status();
}

void ViewService::stop() {
  impl_->draining = true;
  if (impl_->options.drain_s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(impl_->options.drain_s));
  impl_->mission_routes->stop();
  impl_->tiles->stop();
  impl_->server->stop();
}

}  // namespace rgbdcast::service
