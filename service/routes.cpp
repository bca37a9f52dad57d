#include "service/routes.h"

namespace rgbdcast::service {
namespace {

constexpr std::string_view kScenes = "/v1/scenes/";
constexpr std::string_view kMissions = "/v1/missions/";

RouteMatch route(const char* label, const char* allow) { return RouteMatch{label, allow, true}; }

}  // namespace

bool RouteMatch::allows(std::string_view method) const {
  if (!known || method.empty()) return false;
  const std::string_view list = allow;
  size_t start = 0;
  while (start < list.size()) {
    size_t end = list.find(", ", start);
    if (end == std::string_view::npos) end = list.size();
    if (list.substr(start, end - start) == method) return true;
    start = end + 2;
  }
  return false;
}

RouteMatch match_route(std::string_view path) {
  if (path == "/") return route("/", "GET, HEAD");
  if (path == "/healthz") return route("/healthz", "GET, HEAD");
  if (path == "/livez") return route("/livez", "GET, HEAD");
  if (path == "/readyz") return route("/readyz", "GET, HEAD");
  if (path == "/metrics") return route("/metrics", "GET, HEAD");
  if (path == "/v1/scenes") return route("/v1/scenes", "GET, HEAD, POST");
  if (path == "/v1/missions") return route("/v1/missions", "GET, HEAD");
  if (path.substr(0, 6) == "/page/" && path.size() > 6) return route("/page/{file}", "GET, HEAD");
  if (path.substr(0, 13) == "/web/modules/" && path.size() > 13) return route("/web/modules/{path}", "GET, HEAD");
  if (path.substr(0, kMissions.size()) == kMissions) {
    // /v1/missions/{name}[/keyframes|/model.glb|/view|/events]: a malformed name is the handler's 400.
    const std::string_view rest = path.substr(kMissions.size());
    const size_t slash = rest.find('/');
    if (slash == 0 || rest.empty()) return {};
    if (slash == std::string_view::npos) return route("/v1/missions/{name}", "GET, HEAD, DELETE");
    const std::string_view tail = rest.substr(slash);
    if (tail == "/keyframes") return route("/v1/missions/{name}/keyframes", "POST");
    if (tail == "/model.glb") return route("/v1/missions/{name}/model.glb", "GET, HEAD");
    if (tail == "/view") return route("/v1/missions/{name}/view", "GET, HEAD, POST");
    if (tail == "/events") return route("/v1/missions/{name}/events", "GET");
    if (tail == "/tileset.json") return route("/v1/missions/{name}/tileset.json", "GET, HEAD");
    if (tail.substr(0, 7) == "/tiles/") return route("/v1/missions/{name}/tiles/{file}", "GET, HEAD");
    return {};
  }
  if (path.substr(0, kScenes.size()) != kScenes) return {};
  // /v1/scenes/{id}[/model.glb|/view]: the id is any non-empty segment here (a malformed id is the handler's 400).
  const std::string_view rest = path.substr(kScenes.size());
  const size_t slash = rest.find('/');
  if (slash == 0 || rest.empty()) return {};
  if (slash == std::string_view::npos) return route("/v1/scenes/{id}", "GET, HEAD, DELETE");
  const std::string_view tail = rest.substr(slash);
  if (tail == "/model.glb") return route("/v1/scenes/{id}/model.glb", "GET, HEAD");
  if (tail == "/view") return route("/v1/scenes/{id}/view", "GET, HEAD, POST");
  return {};
}

}  // namespace rgbdcast::service
