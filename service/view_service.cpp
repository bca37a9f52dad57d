#include "service/view_service.h"

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <regex>

#include <nlohmann/json.hpp>

#include "gltf/gltf_io.h"
#include "service/http_errors.h"
#include "service/image_encode.h"
#include "service/metrics.h"
#include "service/model_flavors.h"
#include "service/render_pool.h"
#include "service/scene_ingest.h"
#include "service/scene_store.h"
#include "service/view_params.h"

namespace rgbdcast::service {
namespace {

using Clock = std::chrono::steady_clock;

// Set by the pre-routing handler, read by the logger: both run on the thread that serves the request.
thread_local Clock::time_point t_request_start{};

std::string fmt_ms(double ms) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f", ms);
  return buf;
}

void send_error(httplib::Response& res, int status, const std::string& detail) {
  res.status = status;
  res.set_content(error_body(status, detail), "application/json");
}

void send_error(httplib::Response& res, const Error& e) {
  const int status = http_status_for(e.code);
  if (status == 503) res.set_header("Retry-After", "1");
  send_error(res, status, e.message);
}

void send_json(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n", "application/json");
}

// The route pattern a request belongs to: the label of its metrics.
std::string route_of(const std::string& path) {
  static const std::regex kScene("^/v1/scenes/[^/]+$"), kGlb("^/v1/scenes/[^/]+/model\\.glb$"),
      kView("^/v1/scenes/[^/]+/view$");
  if (path == "/" || path == "/healthz" || path == "/metrics" || path == "/v1/scenes") return path;
  if (std::regex_match(path, kScene)) return "/v1/scenes/{id}";
  if (std::regex_match(path, kGlb)) return "/v1/scenes/{id}/model.glb";
  if (std::regex_match(path, kView)) return "/v1/scenes/{id}/view";
  return "other";
}

// The media type without parameters, lower case.
std::string media_type(const std::string& content_type) {
  std::string t = content_type.substr(0, content_type.find(';'));
  while (!t.empty() && t.back() == ' ') t.pop_back();
  for (auto& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return t;
}

nlohmann::json scene_summary(const StoredScene& s) {
  nlohmann::json j = {{"id", s.id}, {"bytes", s.bytes}, {"created_unix_s", s.created_unix_s}};
  for (const char* key : {"points", "triangles", "vertices", "source"})
    if (s.metadata.contains(key)) j[key] = s.metadata[key];
  j["links"] = {{"self", "/v1/scenes/" + s.id},
                {"model", "/v1/scenes/" + s.id + "/model.glb"},
                {"view", "/v1/scenes/" + s.id + "/view?pose=capture"}};
  return j;
}

}  // namespace

struct ViewService::Impl {
  ServeOptions options;
  std::unique_ptr<SceneStore> store;
  std::unique_ptr<RenderPool> pool;
  std::string backend_reason;
  std::mutex reason_mutex;
  Metrics metrics;
  ModelFlavors flavors;
  httplib::Server server;
  int port = 0;

  void routes();
  // Wraps a handler: nothing escapes it, whatever it throws.
  httplib::Server::Handler guarded(std::function<void(const httplib::Request&, httplib::Response&)> f) {
    return [f = std::move(f)](const httplib::Request& req, httplib::Response& res) {
      try {
        f(req, res);
      } catch (const std::exception& e) {
        send_error(res, 500, std::string("unexpected failure: ") + e.what());
      } catch (...) {
        send_error(res, 500, "unexpected failure");
      }
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
  void post_scene(const httplib::Request& req, httplib::Response& res);
  void get_view(const httplib::Request& req, httplib::Response& res);
  void get_glb(const httplib::Request& req, httplib::Response& res);
};

void ViewService::Impl::post_scene(const httplib::Request& req, httplib::Response& res) {
  const std::string type = media_type(req.get_header_value("Content-Type"));
  Result<IngestedScene> ingested = make_error(ErrorCode::kInternal, "unreachable");
  if (type == "model/gltf-binary") {
    ingested = ingest_glb(std::vector<std::uint8_t>(req.body.begin(), req.body.end()));
  } else if (req.is_multipart_form_data()) {
    FrameUpload up;
    for (const char* part : {"color", "depth", "intrinsics"}) {
      if (!req.has_file(part)) {
        send_error(res, 400, std::string("multipart upload lacks the part '") + part +
                                 "' (parts: color, depth, intrinsics)");
        return;
      }
    }
    const auto color = req.get_file_value("color"), depth = req.get_file_value("depth");
    up.color.assign(color.content.begin(), color.content.end());
    up.depth.assign(depth.content.begin(), depth.content.end());
    up.intrinsics_json = req.get_file_value("intrinsics").content;
    up.scratch_dir = options.data_dir + "/scenes";
    ingested = ingest_frame(up);
  } else {
    send_error(res, 415, "Content-Type must be model/gltf-binary (a GLB) or multipart/form-data (color, depth, "
                         "intrinsics); got '" + type + "'");
    return;
  }
  if (!ingested) return send_error(res, ingested.error());
  auto stored = store->put(ingested->glb, ingested->stats);
  if (!stored) return send_error(res, stored.error());
  res.set_header("Location", "/v1/scenes/" + stored->id);
  send_json(res, 201, stored->metadata);
}

void ViewService::Impl::get_view(const httplib::Request& req, httplib::Response& res) {
  auto scene = scene_or_error(req, res);
  if (!scene) return;
  QueryParams params = req.params;
  if (req.method == "POST") params.emplace("camera", req.body);  // the camera JSON as the body (camera_json.h)
  auto request = parse_view_request(params);
  if (!request) return send_error(res, request.error());
  auto out = pool->render(scene->id, *request);
  if (!out) return send_error(res, out.error());
  const auto t0 = Clock::now();
  auto encoded = encode_image(out->color, request->format, request->quality);
  if (!encoded) return send_error(res, encoded.error());
  const double encode_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  metrics.observe_render(to_string(request->mode), out->backend, out->render_ms);
  res.set_header("X-Render-Ms", fmt_ms(out->render_ms));
  res.set_header("X-Readback-Ms", fmt_ms(out->readback_ms));
  res.set_header("X-Encode-Ms", fmt_ms(encode_ms));
  res.set_header("X-Queue-Ms", fmt_ms(out->queue_ms));
  if (out->upload_ms > 0 || out->load_ms > 0) res.set_header("X-Upload-Ms", fmt_ms(out->load_ms + out->upload_ms));
  res.set_header("X-Backend", out->backend);
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

void ViewService::Impl::routes() {
  server.set_payload_max_length(options.max_body_bytes);
  server.set_pre_routing_handler([](const httplib::Request&, httplib::Response&) {
    t_request_start = Clock::now();
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // Called for every response >= 400, ours included: only fills a body when there is none (404 of an unknown
  // route, 413 from the payload limit, 400 of a request the library could not parse).
  const size_t limit_bytes = options.max_body_bytes;
  server.set_error_handler([limit_bytes](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;
    std::string detail;
    switch (res.status) {
      case 404: detail = "no route " + req.method + " " + req.path; break;
      case 413: detail = "request body over the limit of " + std::to_string(limit_bytes) + " bytes (--max-body-mib)"; break;
      default: detail = "request rejected by the HTTP layer"; break;
    }
    res.set_content(error_body(res.status, detail), "application/json");
  });
  server.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "unexpected failure";
    try {
      if (ep) std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what += std::string(": ") + e.what();
    } catch (...) {
    }
    send_error(res, 500, what);
  });
  server.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
    double seconds = 0.0;
    if (t_request_start != Clock::time_point{})
      seconds = std::chrono::duration<double>(Clock::now() - t_request_start).count();
    t_request_start = Clock::time_point{};
    metrics.observe_request(req.method, route_of(req.path), res.status, seconds);
  });

  server.Get("/", guarded([](const httplib::Request&, httplib::Response& res) {
    res.set_content(operator_page_html(), "text/html; charset=utf-8");
  }));
  server.Get("/healthz", guarded([this](const httplib::Request&, httplib::Response& res) {
    send_json(res, 200, {{"status", "ok"}, {"backend", pool->backend()}, {"device", pool->device()},
                         {"scenes", store->count()}});
  }));
  server.Get("/metrics", guarded([this](const httplib::Request&, httplib::Response& res) {
    MetricsGauges g;
    g.scenes_stored = store->count();
    g.bytes_stored = store->total_bytes();
    g.render_queue_depth = pool->queue_depth();
    g.render_rejected = pool->rejected();
    res.set_content(metrics.prometheus_text(g), "text/plain; version=0.0.4; charset=utf-8");
  }));
  server.Post("/v1/scenes", guarded([this](const httplib::Request& req, httplib::Response& res) {
    post_scene(req, res);
  }));
  server.Get("/v1/scenes", guarded([this](const httplib::Request&, httplib::Response& res) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& s : store->list()) list.push_back(scene_summary(s));
    send_json(res, 200, {{"scenes", list}, {"count", list.size()}});
  }));
  server.Get(R"(/v1/scenes/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res) {
    auto s = scene_or_error(req, res);
    if (!s) return;
    nlohmann::json body = s->metadata;
    body["links"] = scene_summary(*s)["links"];
    send_json(res, 200, body);
  }));
  server.Delete(R"(/v1/scenes/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res) {
    auto s = scene_or_error(req, res);
    if (!s) return;
    auto st = store->remove(s->id);
    if (!st) return send_error(res, st.error());
    pool->forget(s->id);
    flavors.forget(s->id);
    res.status = 204;
  }));
  server.Get(R"(/v1/scenes/([^/]+)/model\.glb)", guarded([this](const httplib::Request& req, httplib::Response& res) {
    get_glb(req, res);
  }));
  server.Get(R"(/v1/scenes/([^/]+)/view)", guarded([this](const httplib::Request& req, httplib::Response& res) {
    get_view(req, res);
  }));
  server.Post(R"(/v1/scenes/([^/]+)/view)", guarded([this](const httplib::Request& req, httplib::Response& res) {
    get_view(req, res);
  }));
}

ViewService::ViewService(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ViewService::~ViewService() {
  if (impl_) impl_->server.stop();
}

Result<std::unique_ptr<ViewService>> ViewService::create(const ServeOptions& options) {
  if (options.port < 0 || options.port > 65535)
    return make_error(ErrorCode::kInvalidArgument, "port must be 0..65535");
  if (options.threads < 1 || options.threads > 1024)
    return make_error(ErrorCode::kInvalidArgument, "threads must be 1..1024");
  if (options.max_body_bytes < 1024) return make_error(ErrorCode::kInvalidArgument, "body limit under 1 KiB");
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  auto store = SceneStore::open(options.data_dir);
  if (!store) return store.error();
  impl->store = std::move(*store);

  SceneStore* store_ptr = impl->store.get();
  std::string* reason = &impl->backend_reason;
  std::mutex* reason_mutex = &impl->reason_mutex;
  const BackendChoice choice = options.backend;
  RenderPoolOptions pool_options;
  pool_options.workers = options.renderers;
  pool_options.queue_capacity = options.render_queue;
  auto pool = RenderPool::start(
      pool_options,
      [choice, reason, reason_mutex]() -> Result<std::unique_ptr<Renderer>> {
        auto sel = create_renderer(choice);
        if (!sel) return sel.error();
        std::lock_guard lock(*reason_mutex);
        *reason = sel->reason;
        return std::move(sel->renderer);
      },
      [store_ptr](const std::string& id) -> Result<std::shared_ptr<const Scene>> {
        auto bytes = store_ptr->read_glb(id);
        if (!bytes) return bytes.error();
        auto scene = decode_glb(bytes->data(), bytes->size());
        if (!scene) return make_error(ErrorCode::kInternal, "stored scene " + id + " no longer decodes: " +
                                                                 scene.error().message);
        return std::shared_ptr<const Scene>(std::make_shared<Scene>(std::move(*scene)));
      });
  if (!pool) return pool.error();
  impl->pool = std::move(*pool);

  const int threads = options.threads;
  impl->server.new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<size_t>(threads)); };
  impl->server.set_keep_alive_max_count(1000);
  impl->server.set_read_timeout(30, 0);
  impl->server.set_write_timeout(30, 0);
  impl->routes();
  if (options.port == 0) {
    const int p = impl->server.bind_to_any_port(options.bind);
    if (p <= 0) return make_error(ErrorCode::kIo, "cannot bind " + options.bind + " (any port)");
    impl->port = p;
  } else {
    if (!impl->server.bind_to_port(options.bind, options.port))
      return make_error(ErrorCode::kIo, "cannot bind " + options.bind + ":" + std::to_string(options.port) +
                                            " (in use, or not an address of this machine)");
    impl->port = options.port;
  }
  return std::unique_ptr<ViewService>(new ViewService(std::move(impl)));
}

Result<nlohmann::json> ViewService::import_glb_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot read " + path);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  const std::string etag = etag_of(bytes.data(), bytes.size());
  for (const auto& s : impl_->store->list())
    if (s.etag == etag) return s.metadata;
  auto ingested = ingest_glb(std::move(bytes));
  if (!ingested) return make_error(ingested.error().code, path + ": " + ingested.error().message);
  auto stored = impl_->store->put(ingested->glb, ingested->stats);
  if (!stored) return stored.error();
  return stored->metadata;
}

int ViewService::port() const { return impl_->port; }
std::string ViewService::backend() const { return impl_->pool->backend(); }
std::string ViewService::backend_reason() const { return impl_->backend_reason; }
std::string ViewService::device() const { return impl_->pool->device(); }
size_t ViewService::scene_count() const { return impl_->store->count(); }

Status ViewService::run() {
  if (!impl_->server.listen_after_bind()) return make_error(ErrorCode::kIo, "the listener stopped with an error");
  return ok_status();
}

void ViewService::stop() { impl_->server.stop(); }

}  // namespace rgbdcast::service
