#pragma once
// The operator page's files (service/page/, embedded at build time) and the npm modules it imports (three.js,
// 3DTilesRendererJS and three's decoders), both served by `rgbdcast serve` itself so that the page loads nothing from
// another host:
//   GET /page/{file}          an embedded file of the page (app.js, local_view.js, ...); 404 for any other name
//   GET /web/modules/{path}   a file under the modules folder (tools/node_modules after `npm ci`), only under
//                             three/build/, three/examples/jsm/ and 3d-tiles-renderer/build/, only .js and .wasm;
//                             404 when the folder or the file is missing (the page then renders on the server).
// Names with "..", empty segments or characters outside [A-Za-z0-9._/-] are 400. httplib.h: see http_reply.h.
#include <httplib.h>

#include <functional>
#include <optional>
#include <string>

namespace rgbdcast::service {

// The embedded page file called `name` (e.g. "app.js"), or nullopt.
std::optional<std::string> operator_page_file(const std::string& name);

// The media type served for a module path, or "" when the path is not one the page may load (see above).
std::string web_module_media_type(const std::string& path);

class WebAssets {
 public:
  using Guard = std::function<httplib::Server::Handler(httplib::Server::Handler)>;
  // modules_dir: the folder holding three/ and 3d-tiles-renderer/ ("" serves no modules).
  explicit WebAssets(std::string modules_dir) : modules_dir_(std::move(modules_dir)) {}
  // Whether the modules the page imports first are there (reported at start and in /healthz).
  bool modules_present() const;
  void install(httplib::Server& server, const Guard& guard) const;

 private:
  std::string modules_dir_;
};

}  // namespace rgbdcast::service
