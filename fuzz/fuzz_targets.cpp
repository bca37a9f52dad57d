#include "fuzz/fuzz_targets.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
#include <cstdio>
#include <cstdlib>
#include <dlfcn.h>
#include <filesystem>
#include <string>
#include <string_view>
#include <unistd.h>
#include <vector>

#include "gltf/draco_header.h"
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "input/pcd_header.h"
#include "input/pcd_source.h"
#include "keyframes/trajectory_io.h"
#include "scene/intrinsics.h"
#include "service/upload_body.h"
#include "service/view_params.h"

namespace rgbdcast::fuzz {
namespace {

// An error is one non-empty line (the service writes it into its JSON body, replacing invalid UTF-8).
void check_error(const Error& e) {
  if (e.message.empty() || e.message.find('\n') != std::string::npos) std::abort();
}

std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}

// For readers that take files only (PCL, rosbag): one file of this process in the temporary folder, rewritten with
// each input and removed when the fuzzer ends (a file per run would pile up in /tmp).
class ScratchFile {
 public:
  explicit ScratchFile(const std::string& tag)
      : path_((std::filesystem::temp_directory_path() /
               ("rgbdcast-fuzz-" + tag + "-" + std::to_string(getpid()) + "." + tag))
                  .string()) {}
  ~ScratchFile() { std::remove(path_.c_str()); }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;
  const std::string& path() const { return path_; }
  // The input bytes as the file's whole content.
  bool write(const std::uint8_t* data, size_t size) const {
    FILE* f = std::fopen(path_.c_str(), "wb");
    if (!f) return false;
    const bool ok = std::fwrite(data, 1, size, f) == size;
    return std::fclose(f) == 0 && ok;
  }

 private:
  std::string path_;
};

}  // namespace

// decode_glb on arbitrary bytes (the body of POST /v1/scenes). Any input must give a Scene or a one-line
// kInvalidInput/kEmpty error, within the default limits; ASan/UBSan abort on anything else.
void glb(const std::uint8_t* data, size_t size) {
  auto scene = rgbdcast::decode_glb(data, size);
  if (scene.ok()) {
    for (const auto& n : scene->nodes)
      for (auto i : n.mesh.indices)
        if (i >= n.mesh.positions.size()) std::abort();  // an accepted scene is consistent
  } else {
    check_error(scene.error());
  }
}

// The Draco decoder behind draco_decompress's checks: the bytes after the first four are a Draco bitstream inside a
// fixed GLB (POSITION float VEC3, TEXCOORD_0 float VEC2, uint32 indices). The declared point count is the input's
// first four bytes; the declared face count is the header's (when it parses), so that mutations reach Draco itself.
// Any input must give a consistent Scene or a one-line error, within the default limits.
void draco(const std::uint8_t* data, size_t size) {
  if (size < 4) return;
  const std::uint32_t points = le32(data);
  const std::uint8_t* bits = data + 4;
  const size_t n = size - 4;
  auto header = rgbdcast::glb::read_draco_header(bits, n);
  const std::uint64_t faces = header.ok() ? header->num_faces : 1;
  nlohmann::json doc = {
      {"asset", {{"version", "2.0"}}},
      {"extensionsUsed", {"KHR_draco_mesh_compression"}},
      {"extensionsRequired", {"KHR_draco_mesh_compression"}},
      {"buffers", {{{"byteLength", n}}}},
      {"bufferViews", {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", n}}}},
      {"accessors",
       {{{"componentType", 5126}, {"count", points}, {"type", "VEC3"}, {"min", {0, 0, 0}}, {"max", {1, 1, 1}}},
        {{"componentType", 5126}, {"count", points}, {"type", "VEC2"}},
        {{"componentType", 5125}, {"count", 3 * faces}, {"type", "SCALAR"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}},
            {"indices", 2},
            {"extensions",
             {{"KHR_draco_mesh_compression",
               {{"bufferView", 0}, {"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}}}}}}}}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"scenes", {{{"nodes", {0}}}}},
      {"scene", 0}};
  const std::vector<std::uint8_t> bin(bits, bits + n);
  const std::vector<std::uint8_t> glb_bytes = rgbdcast::glb::pack_glb(doc.dump(), bin);
  glb(glb_bytes.data(), glb_bytes.size());
}

// parse_intrinsics_json on arbitrary text (the "intrinsics" part of a frame upload).
void intrinsics(const std::uint8_t* data, size_t size) {
  auto k = rgbdcast::parse_intrinsics_json(std::string_view(reinterpret_cast<const char*>(data), size));
  if (k.ok() && !(k->fx > 0 && k->fy > 0 && k->width >= 1 && k->height >= 1 && k->depth_scale > 0)) std::abort();
  if (!k.ok()) check_error(k.error());
}

// PNG/JPEG bytes -> decode_color and decode_depth16 (upload limits), then make_frame with a distorted
// camera of the decoded size, as the frame upload does.
void frame_decode(const std::uint8_t* data, size_t size) {
  const std::vector<unsigned char> bytes(data, data + size);
  auto color = rgbdcast::decode_color(bytes, "color");
  auto depth = rgbdcast::decode_depth16(bytes, "depth");
  if (depth.ok()) {
    rgbdcast::Intrinsics k;
    k.width = depth->cols;
    k.height = depth->rows;
    k.fx = k.fy = 525.0;
    k.cx = 0.5 * k.width;
    k.cy = 0.5 * k.height;
    k.distortion = {0.26, -0.95, -0.005, 0.003, 1.16};
    k.depth_scale = 5000.0;
    cv::Mat grey(depth->rows, depth->cols, CV_8UC3, cv::Scalar(90, 90, 90));
    (void)rgbdcast::make_frame(grey, *depth, k);
  }
}

// the multipart frame upload up to (not including) the reduction: intrinsics JSON, colour and depth bytes
// -> parse_intrinsics_json, decode_color, decode_depth16, make_frame. Input framing (seeds in corpus/): two
// little-endian u32 lengths, the intrinsics text and the colour bytes, then the rest is the depth bytes.
void frame_upload(const std::uint8_t* data, size_t size) {
  if (size < 8) return;
  const size_t n_json = le32(data), n_color = le32(data + 4);
  const size_t rest = size - 8;
  if (n_json > rest || n_color > rest - n_json) return;
  const std::uint8_t* p = data + 8;
  auto k = rgbdcast::parse_intrinsics_json(std::string_view(reinterpret_cast<const char*>(p), n_json), "intrinsics");
  const std::vector<unsigned char> color_bytes(p + n_json, p + n_json + n_color);
  const std::vector<unsigned char> depth_bytes(p + n_json + n_color, data + size);
  auto color = rgbdcast::decode_color(color_bytes, "color");
  auto depth = rgbdcast::decode_depth16(depth_bytes, "depth");
  if (k.ok() && color.ok() && depth.ok()) (void)rgbdcast::make_frame(*color, *depth, *k);
}

namespace {

// A request's bytes for httplib::Server (what GateStream gives it in the server, service/connection_gate.cpp);
// the answer's bytes are counted and dropped.
class MemoryStream final : public httplib::Stream {
 public:
  explicit MemoryStream(std::string request) : in_(std::move(request)) {}
  bool is_readable() const override { return true; }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, size_t size) override {
    const size_t n = std::min(size, in_.size() - off_);
    std::memcpy(ptr, in_.data() + off_, n);
    off_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char*, size_t size) override { return static_cast<ssize_t>(size); }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 1;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 2;
  }
  socket_t socket() const override { return INVALID_SOCKET; }

 private:
  std::string in_;
  size_t off_ = 0;
};

// POST /v1/scenes as the server routes a multipart upload: the route's body read and frame decoding.
class MultipartServer : public httplib::Server {
 public:
  static constexpr size_t kLimit = 4u << 20;
  MultipartServer() {
    set_payload_max_length(kLimit);
    Post("/v1/scenes", [](const httplib::Request& req, httplib::Response& res, const httplib::ContentReader& reader) {
      if (!req.is_multipart_form_data()) return;
      service::FrameParts parts;
      if (auto refused = service::read_frame_parts(reader, kLimit, &parts)) {
        if (refused->status < 400 || refused->status > 499 || refused->detail.find('\n') != std::string::npos)
          std::abort();
        res.status = refused->status;
        return;
      }
      auto frame = service::decode_frame_parts(parts.color, parts.depth, parts.intrinsics_json, 1920, 1080);
      if (!frame) {
        check_error(frame.error());
        res.status = 422;
        return;
      }
      if (frame->color_rgb.size() != frame->depth_m.size() || frame->depth_m.type() != CV_32FC1 ||
          frame->color_rgb.cols > 1920 || frame->color_rgb.rows > 1080)
        std::abort();
      res.status = 201;
    });
    set_exception_handler([](const httplib::Request&, httplib::Response&, std::exception_ptr) { std::abort(); });
  }
  void serve(std::string request) {
    MemoryStream stream(std::move(request));
    bool closed = false;
    process_request(stream, true, closed, nullptr);
  }
};

}  // namespace

// The multipart frame upload from the body's bytes on, through httplib's request and multipart parsing and the
// route's own code (service/upload_body.h) up to the RgbdFrame the server would reduce. Input: the boundary up to
// the first '\n' (1..70 bytes), then the body.
void multipart(const std::uint8_t* data, size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const size_t eol = in.find('\n');
  if (eol == std::string_view::npos || eol == 0 || eol > 70) return;
  const std::string_view boundary = in.substr(0, eol), body = in.substr(eol + 1);
  if (boundary.find_first_of("\r\0") != std::string_view::npos) return;  // not a header value
  static MultipartServer server;
  std::string request = "POST /v1/scenes HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: multipart/form-data; boundary=";
  request.append(boundary);
  request += "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n";
  request.append(body);
  server.serve(std::move(request));
}

// check_pcd_header on arbitrary bytes, and when it passes, the whole PCD frame read (PCL's reader on a
// file holding the bytes: PCL reads files only).
void pcd(const std::uint8_t* data, size_t size) {
  if (!rgbdcast::check_pcd_header(data, size).ok()) return;
  static const ScratchFile file("pcd");
  if (!file.write(data, size)) return;
  rgbdcast::Intrinsics k;
  k.fx = k.fy = 525.0;
  k.width = 640;
  k.height = 480;
  auto src = rgbdcast::open_pcd_source(file.path(), k);
  if (src.ok()) (void)(*src)->frame(0);
}

// the trajectory parsers (TUM, Redwood .log, ICL-NUIM) on arbitrary text; the first byte picks the format.
void trajectory(const std::uint8_t* data, size_t size) {
  if (size < 1) return;
  const auto format = static_cast<rgbdcast::TrajectoryFormat>(data[0] % 3);
  auto tr = rgbdcast::parse_trajectory(std::string_view(reinterpret_cast<const char*>(data + 1), size - 1), format);
  if (tr.ok()) {
    if (tr->poses.empty()) std::abort();
    for (const auto& p : tr->poses)
      if (!p.camera_to_world.allFinite()) std::abort();
  }
}

// a ROS 1 bag (input/rosbag_source.cpp through Debian's rosbag_storage, which reads files only: the bytes go to a
// file first) on the default topics: open, index, then every frame up to 4. An accepted frame is consistent.
void rosbag(const std::uint8_t* data, size_t size) {
  // Every rosbag::Bag loads its encryptor plugin through pluginlib and unloads it again: relocating and finalising
  // that library was half of an execution, and what it leaves behind made libFuzzer scan for leaks after each one
  // (4x slower). Holding one reference keeps it loaded; the target runs the same code either way.
  static void* const plugin =
      dlopen("/usr/lib/x86_64-linux-gnu/ros/librosbag_default_encryption_plugins.so", RTLD_NOW | RTLD_NODELETE);
  (void)plugin;
  static const ScratchFile file("bag");
  if (!file.write(data, size)) return;
  rgbdcast::SourceOptions options;
  auto src = rgbdcast::open_frame_source(file.path(), options);
  if (!src.ok()) return check_error(src.error());
  for (size_t i = 0; i < (*src)->size() && i < 4; ++i) {
    auto frame = (*src)->frame(i);
    if (!frame.ok()) {
      check_error(frame.error());
      continue;
    }
    if (frame->color_rgb.size() != frame->depth_m.size() || frame->depth_m.type() != CV_32FC1) std::abort();
  }
}

// the view query parser (service/view_params.cpp) and the camera it builds. The input is a query string
// split on '&' and the first '=' (cpp-httplib has already percent-decoded it); make_view_camera runs with no capture
// camera and with one.
void view_query(const std::uint8_t* data, size_t size) {
  const std::string q(reinterpret_cast<const char*>(data), size);
  rgbdcast::service::QueryParams params;
  size_t pos = 0;
  while (pos <= q.size()) {
    size_t amp = q.find('&', pos);
    if (amp == std::string::npos) amp = q.size();
    const std::string pair = q.substr(pos, amp - pos);
    const size_t eq = pair.find('=');
    params.emplace(pair.substr(0, eq), eq == std::string::npos ? "" : pair.substr(eq + 1));
    pos = amp + 1;
  }
  auto req = rgbdcast::service::parse_view_request(params);
  if (!req.ok()) {  // one printable line: what the client sent is quoted as \xNN (service/http_errors.h)
    check_error(req.error());
    for (unsigned char c : req.error().message)
      if (c < 0x20 || c >= 0x7f) std::abort();
    return;
  }
  (void)rgbdcast::service::make_view_camera(*req, {});
  rgbdcast::CaptureCamera cam;
  cam.intrinsics.fx = cam.intrinsics.fy = 525.0;
  cam.intrinsics.cx = 319.5;
  cam.intrinsics.cy = 239.5;
  cam.intrinsics.width = 640;
  cam.intrinsics.height = 480;
  (void)rgbdcast::service::make_view_camera(*req, {cam});
}

}  // namespace rgbdcast::fuzz
