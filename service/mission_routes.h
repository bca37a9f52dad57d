#pragma once
// The /v1/missions routes (wire contract in service/openapi.yaml):
//   POST   /v1/missions/{name}/keyframes?seq=N&pose=tx,ty,tz,qx,qy,qz,qw[&captured=T]   (a keyframe GLB)
//   GET    /v1/missions, /v1/missions/{name}, /v1/missions/{name}/model.glb, /v1/missions/{name}/view?...
//   GET    /v1/missions/{name}/events    (Server-Sent Events: "keyframe" events, and "tileset" when it changed)
//   GET    /v1/missions/{name}/tileset.json, /v1/missions/{name}/tiles/{file}   (3D Tiles 1.1, service/mission_tiles.h)
//   DELETE /v1/missions/{name}
// Keyframe posts are idempotent on (name, seq) and serialized (one at a time, over every mission): each is decoded
// (untrusted GLB) on the HTTP thread under the upload slots, stored (service/mission_store.h), appended to the mission
// resident on every renderer (RenderPool::append), and only then answered, so "available" is when views include it.
// Event streams: an SSE response holds an HTTP worker for as long as it is open (cpp-httplib writes chunked content
// from the thread serving the request), so at most max_event_streams are open at once (more get 503 with
// Retry-After), each lasts at most event_stream_max_s (then it ends and the client's EventSource reconnects with
// Last-Event-ID, losing nothing), and a client that does not read is dropped by the gate's write timeout
// (service/connection_gate.h). ViewService counts the streams among the threads it needs.
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <vector>
#include <string>

// Eigen before httplib.h: a macro of the headers httplib pulls in breaks Eigen's product kernels otherwise.
#include "service/mission_store.h"
#include "service/mission_tiles.h"
#include "service/render_pool.h"
#include "service/view_params.h"
#include "service/http_reply.h"

namespace rgbdcast::service {

struct MissionRouteOptions {
  size_t max_body_bytes = 64u << 20;
  int max_event_streams = 4;
  double event_stream_max_s = 300.0;  // one SSE response at most this long
  double keep_alive_s = 15.0;         // a ": keep-alive" comment after this long without an event
  size_t max_model_keyframes = 300;   // model.glb without max-error: missions longer than this get 409 (view_service.h)
};

// The key of a mission among the render pool's scenes ("mission/<name>": scene ids are hex, so never one of these).
std::string mission_scene_key(const std::string& name);

// A page of GET /v1/missions/{name}: the keyframes with seq > after (every seq when after is -1), at most limit.
inline constexpr size_t kDefaultKeyframePage = 100, kMaxKeyframePage = 1000;
struct KeyframePage {
  std::int64_t after = -1;
  size_t limit = kDefaultKeyframePage;
};
// ?after=SEQ&limit=N (both optional, each at most once, nothing else): kInvalidArgument naming what is wrong.
Result<KeyframePage> parse_keyframe_page(const std::multimap<std::string, std::string>& params);

class MissionRoutes {
 public:
  // render_view runs `render` and answers its image as the request asks (the scene view route's own code).
  using RenderView = std::function<void(const httplib::Request&, const ViewRequest&,
                                        const std::function<Result<RenderOutput>()>& render, httplib::Response&)>;
  MissionRoutes(MissionRouteOptions options, MissionStore& missions, MissionTiles& tiles, RenderPool& pool,
                Slots& uploads, RenderView render_view);
  ~MissionRoutes();
  // Registers the routes; every handler runs inside `guard` (which turns anything thrown into a 500).
  using Guard = std::function<httplib::Server::Handler(httplib::Server::Handler)>;
  using GuardReader =
      std::function<httplib::Server::HandlerWithContentReader(httplib::Server::HandlerWithContentReader)>;
  void install(httplib::Server& server, const Guard& guard, const GuardReader& guard_reader);
  // Ends every open event stream (the server is stopping).
  void stop();
  int open_streams() const { return streams_.used(); }

 private:
  void post_keyframe(const httplib::Request& req, httplib::Response& res, const httplib::ContentReader& reader);
  void get_mission(const httplib::Request& req, httplib::Response& res);
  void get_model(const httplib::Request& req, httplib::Response& res);
  void get_view(const httplib::Request& req, httplib::Response& res);
  void get_events(const httplib::Request& req, httplib::Response& res);
  void get_tileset(const httplib::Request& req, httplib::Response& res);
  void get_tile(const httplib::Request& req, httplib::Response& res);
  void delete_mission(const httplib::Request& req, httplib::Response& res);

  MissionRouteOptions options_;
  MissionStore& missions_;
  MissionTiles& tiles_;
  RenderPool& pool_;
  Slots& uploads_;
  RenderView render_view_;
  Slots streams_;
  std::mutex post_mutex_;  // keyframe posts, one at a time
  // The last model.glb encoded per mission and flavour (key "name?flavour"; ?flavor= as for scenes,
  // service/model_flavors.h), with the keyframes it was made of ("seq:etag ..."): encoded again only when the
  // mission changed.
  struct CachedModel {
    std::string made_of, etag;
    std::shared_ptr<const std::vector<std::uint8_t>> glb;
  };
  std::mutex model_mutex_;
  std::map<std::string, CachedModel> models_;
  // tileset.json gzipped, per mission, for the snapshot last asked for: compressed once per version (it grows with
  // the tiles: 0.94 MB at 5,000 keyframes) rather than by httplib for every client.
  struct GzippedTileset {
    std::weak_ptr<const tiles::TilesetSnapshot> of;  // expired, or another, once the tileset has moved on
    std::shared_ptr<const std::string> bytes;
  };
  std::mutex tileset_mutex_;
  std::map<std::string, GzippedTileset> gzipped_tilesets_;
  std::atomic<bool> stopping_{false};
};

}  // namespace rgbdcast::service
