#include "service/web_assets.h"

#include <filesystem>
#include <fstream>
#include <iterator>

#include "service/http_gzip.h"
#include "service/http_reply.h"

namespace rgbdcast::service {
namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

bool starts_with(const std::string& s, const std::string& head) { return s.rfind(head, 0) == 0; }

// Only plain relative names: no "..", no empty or hidden segments, a small alphabet.
bool is_plain_path(const std::string& path) {
  if (path.empty() || path.size() > 200 || path.front() == '/' || path.back() == '/') return false;
  for (char c : path)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-' || c == '/')) return false;
  size_t start = 0;
  while (start <= path.size()) {
    size_t end = path.find('/', start);
    if (end == std::string::npos) end = path.size();
    const std::string segment = path.substr(start, end - start);
    if (segment.empty() || segment.front() == '.') return false;
    start = end + 1;
  }
  return true;
}

}  // namespace

std::shared_ptr<const WebAssets::Module> WebAssets::module(const std::string& path) const {
  namespace fs = std::filesystem;
  const std::string file = modules_dir_ + "/" + path;
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec) return nullptr;
  const auto mtime = fs::last_write_time(file, ec);
  if (ec) return nullptr;
  const long long stamp = static_cast<long long>(size) * 1000003LL + mtime.time_since_epoch().count();
  {
    std::lock_guard lock(mutex_);
    auto it = modules_.find(path);
    if (it != modules_.end() && it->second->stamp == stamp) return it->second;
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) return nullptr;
  auto m = std::make_shared<Module>();
  m->bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  m->stamp = stamp;
  m->gzipped = gzip(m->bytes, 9);  // once per module: the smallest
  if (m->gzipped.size() >= m->bytes.size()) m->gzipped.clear();
  std::lock_guard lock(mutex_);
  modules_[path] = m;
  return m;
}

std::string web_module_media_type(const std::string& path) {
  if (!is_plain_path(path)) return "";
  if (!starts_with(path, "three/build/") && !starts_with(path, "three/examples/jsm/") &&
      !starts_with(path, "3d-tiles-renderer/build/"))
    return "";
  if (ends_with(path, ".js")) return "text/javascript; charset=utf-8";
  if (ends_with(path, ".wasm")) return "application/wasm";
  return "";
}

bool WebAssets::modules_present() const {
  std::error_code ec;
  return !modules_dir_.empty() && std::filesystem::is_regular_file(modules_dir_ + "/three/build/three.module.js", ec) &&
         std::filesystem::is_regular_file(modules_dir_ + "/3d-tiles-renderer/build/index.three.js", ec);
}

void WebAssets::install(httplib::Server& server, const Guard& guard) const {
  using Req = const httplib::Request&;
  using Res = httplib::Response&;
  server.Get(R"(/page/([^/]+))", guard([](Req req, Res res) {
               const std::string name = req.matches[1].str();
               auto file = operator_page_file(name);
               if (!file) return send_error(res, 404, "no page file " + name.substr(0, 100));
               res.set_header("Cache-Control", "no-cache");
               res.set_content(*file,
                               ends_with(name, ".js") ? "text/javascript; charset=utf-8" : "text/plain; charset=utf-8");
             }));
  server.Get(R"(/web/modules/(.+))", guard([this, dir = modules_dir_](Req req, Res res) {
               const std::string path = req.matches[1].str();
               if (!is_plain_path(path)) return send_error(res, 400, "malformed module path");
               const std::string type = web_module_media_type(path);
               if (type.empty()) return send_error(res, 404, "not a module the page loads: " + path.substr(0, 100));
               if (dir.empty())
                 return send_error(res, 404, "no modules folder (serve --web-modules); the page renders on the server");
               auto m = module(path);
               if (!m)
                 return send_error(res, 404,
                                   "module " + path.substr(0, 100) +
                                       " is not installed (npm ci in tools/); the page renders on the server");
               // The modules change only when tools/package.json's pins do; an hour of caching spares the reloads.
               res.set_header("Cache-Control", "public, max-age=3600");
               res.set_header("Vary", "Accept-Encoding");
               const bool gzipped = !m->gzipped.empty() && accepts_gzip(req);
               if (gzipped) res.set_header("Content-Encoding", "gzip");
               send_shared(res, std::shared_ptr<const std::string>(m, gzipped ? &m->gzipped : &m->bytes), type);
             }));
}

}  // namespace rgbdcast::service
