#pragma once
// The operator page's files (service/page/, embedded at build time) and the npm modules it imports (three.js,
// 3DTilesRendererJS and three's decoders), both served by `rgbdcast serve` itself so that the page loads nothing from
// another host:
//   GET /page/{file}          an embedded file of the page (app.js, local_view.js, ...); 404 for any other name
//   GET /web/modules/{path}   a file under the modules folder (tools/node_modules after `npm ci`), only under
//                             three/build/, three/examples/jsm/ and 3d-tiles-renderer/build/, only .js and .wasm;
//                             404 when the folder or the file is missing (the page then renders on the server).
// Names with "..", empty segments or characters outside [A-Za-z0-9._/-] are 400. httplib.h: see http_reply.h.
// A module is read and gzipped once (again when its file changes) and sent with Content-Encoding: gzip to clients
// that accept it, as is to the others: httplib would otherwise compress each answer itself, with brotli at its
// slowest quality when the client accepts br (three.core.js: 5.5 s of one core per request).
#include <httplib.h>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
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

  struct Module {
    std::string bytes, gzipped;  // gzipped is empty when compression did not pay
    long long stamp = 0;         // the file's size and modification time when read
  };

 private:
  // The module at `path` (checked by the caller), read and compressed on first use; null when the file is missing.
  std::shared_ptr<const Module> module(const std::string& path) const;

  std::string modules_dir_;
  mutable std::mutex mutex_;
  mutable std::map<std::string, std::shared_ptr<const Module>> modules_;
};

}  // namespace rgbdcast::service
