// encode_glb / write_glb_file: Scene -> tinygltf::Model -> GLB (then EXT_meshopt_compression when asked).
#include <tiny_gltf.h>

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "base/atomic_file.h"
#include "base/stopwatch.h"
#include "gltf/color_space.h"
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "scene/image_probe.h"
#include "gltf/json_value.h"
#include "gltf/meshopt_buffers.h"
#include "gltf/draco_buffers.h"

namespace rgbdcast {
namespace {

constexpr int kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT, kShort = TINYGLTF_COMPONENT_TYPE_SHORT,
              kUShort = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, kUInt = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;

Error invalid(const std::string& what) { return make_error(ErrorCode::kInvalidArgument, "glTF export: " + what); }

std::vector<double> matrix_values(const Eigen::Matrix4d& m) {
  std::vector<double> v(16);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) v[c * 4 + r] = m(r, c);  // glTF: column-major
  return v;
}

class ModelBuilder {
 public:
  explicit ModelBuilder(const GlbWriteOptions& o) : opt_(o) {
    model_.buffers.emplace_back();
    model_.asset.version = "2.0";
    model_.asset.generator = o.generator;
  }

  // Appends bytes (aligned to 4) as a bufferView; stride 0 = tightly packed (indices, images).
  int add_view(const void* data, size_t size, size_t stride, int target, bool geometry) {
    auto& buf = model_.buffers[0].data;
    while (buf.size() % 4) buf.push_back(0);
    tinygltf::BufferView v;
    v.buffer = 0;
    v.byteOffset = buf.size();
    v.byteLength = size;
    v.byteStride = stride;
    v.target = target;
    const auto* p = static_cast<const std::uint8_t*>(data);
    buf.insert(buf.end(), p, p + size);
    model_.bufferViews.push_back(v);
    (geometry ? geometry_bytes_ : texture_bytes_) += size;
    return static_cast<int>(model_.bufferViews.size() - 1);
  }

  int add_accessor(int view, int component, bool normalized, size_t count, int type, std::vector<double> min = {},
                   std::vector<double> max = {}) {
    tinygltf::Accessor a;
    a.bufferView = view;
    a.componentType = component;
    a.normalized = normalized;
    a.count = count;
    a.type = type;
    a.minValues = std::move(min);
    a.maxValues = std::move(max);
    model_.accessors.push_back(a);
    return static_cast<int>(model_.accessors.size() - 1);
  }

  // POSITION: float, or int16 with the dequantization returned in *node (translation + uniform scale).
  int add_positions(const std::vector<Eigen::Vector3f>& pos, tinygltf::Node* node) {
    Eigen::Vector3f lo = pos[0], hi = pos[0];
    for (const auto& p : pos) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    if (!opt_.quantize) {
      std::vector<float> data(pos.size() * 3);
      for (size_t i = 0; i < pos.size(); ++i)
        for (int k = 0; k < 3; ++k) data[3 * i + k] = pos[i][k];
      const int v = add_view(data.data(), data.size() * 4, 12, TINYGLTF_TARGET_ARRAY_BUFFER, true);
      return add_accessor(v, kFloat, false, pos.size(), TINYGLTF_TYPE_VEC3, {lo.x(), lo.y(), lo.z()},
                          {hi.x(), hi.y(), hi.z()});
    }
    const Eigen::Vector3d centre = 0.5 * (lo.cast<double>() + hi.cast<double>());
    const double extent = (hi - lo).cast<double>().maxCoeff();
    const double step = std::max({opt_.position_quantum_m, extent / 65000.0, 1e-9});
    std::vector<std::int16_t> data(pos.size() * 4, 0);  // stride 8: x y z pad
    Eigen::Vector3i qlo = Eigen::Vector3i::Constant(32767), qhi = Eigen::Vector3i::Constant(-32767);
    for (size_t i = 0; i < pos.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        const int q = static_cast<int>(std::lround((pos[i][k] - centre[k]) / step));
        data[4 * i + k] = static_cast<std::int16_t>(q);
        qlo[k] = std::min(qlo[k], q);
        qhi[k] = std::max(qhi[k], q);
      }
    node->translation = {centre.x(), centre.y(), centre.z()};
    node->scale = {step, step, step};
    const int v = add_view(data.data(), data.size() * 2, 8, TINYGLTF_TARGET_ARRAY_BUFFER, true);
    return add_accessor(v, kShort, false, pos.size(), TINYGLTF_TYPE_VEC3,
                        {double(qlo.x()), double(qlo.y()), double(qlo.z())},
                        {double(qhi.x()), double(qhi.y()), double(qhi.z())});
  }

  // TEXCOORD_0. Quantized: UVs that all sit on texel corners (the atlas puts every vertex on one) are stored as
  // texel coordinates in uint16 with KHR_texture_transform scaling them by 1/size; other UVs in [0,1] as uint16 in
  // 1/8 texel units the same way (error <= 1/16 texel) when the texture is at most 8191 texels wide. Small, regular
  // deltas are what meshopt compresses well. Otherwise normalized uint16, or float for UVs outside [0,1].
  // *units_per_texel is 0 when no texture transform is needed.
  int add_uvs(const std::vector<Eigen::Vector2f>& uvs, int tex_w, int tex_h, int* units_per_texel) {
    *units_per_texel = 0;
    bool unit = true, on_texels = opt_.quantize && tex_w > 0 && tex_h > 0 && tex_w <= 65535 && tex_h <= 65535;
    for (const auto& uv : uvs) {
      unit = unit && uv.x() >= 0 && uv.x() <= 1 && uv.y() >= 0 && uv.y() <= 1;
      if (on_texels) {
        const double x = double(uv.x()) * tex_w, y = double(uv.y()) * tex_h;
        on_texels = std::abs(x - std::round(x)) < 2e-3 && std::abs(y - std::round(y)) < 2e-3 && x >= 0 && y >= 0 &&
                    x <= 65535 && y <= 65535;
      }
    }
    const int units = on_texels ? 1
                      : (opt_.quantize && unit && tex_w > 0 && tex_h > 0 && 8 * tex_w <= 65535 && 8 * tex_h <= 65535)
                          ? 8
                          : 0;
    if (units > 0) {
      std::vector<std::uint16_t> data(uvs.size() * 2);
      for (size_t i = 0; i < uvs.size(); ++i) {
        data[2 * i] = static_cast<std::uint16_t>(std::lround(double(uvs[i].x()) * tex_w * units));
        data[2 * i + 1] = static_cast<std::uint16_t>(std::lround(double(uvs[i].y()) * tex_h * units));
      }
      const int v = add_view(data.data(), data.size() * 2, 4, TINYGLTF_TARGET_ARRAY_BUFFER, true);
      uses_quantization_ = uses_texture_transform_ = true;
      *units_per_texel = units;
      return add_accessor(v, kUShort, false, uvs.size(), TINYGLTF_TYPE_VEC2);
    }
    if (opt_.quantize && unit) {
      std::vector<std::uint16_t> data(uvs.size() * 2);
      for (size_t i = 0; i < uvs.size(); ++i)
        for (int k = 0; k < 2; ++k) data[2 * i + k] = static_cast<std::uint16_t>(std::lround(uvs[i][k] * 65535.0));
      const int v = add_view(data.data(), data.size() * 2, 4, TINYGLTF_TARGET_ARRAY_BUFFER, true);
      uses_quantization_ = true;
      return add_accessor(v, kUShort, true, uvs.size(), TINYGLTF_TYPE_VEC2);
    }
    std::vector<float> data(uvs.size() * 2);
    for (size_t i = 0; i < uvs.size(); ++i) data[2 * i] = uvs[i].x(), data[2 * i + 1] = uvs[i].y();
    const int v = add_view(data.data(), data.size() * 4, 8, TINYGLTF_TARGET_ARRAY_BUFFER, true);
    return add_accessor(v, kFloat, false, uvs.size(), TINYGLTF_TYPE_VEC2);
  }

  // COLOR_0: linear RGB as normalized uint16 (stride 8); float for compat (stride 12), which every reader takes.
  int add_colors(const std::vector<Rgb8>& colors) {
    if (opt_.flavor == GlbFlavor::kCompat) {
      std::vector<float> data(colors.size() * 3);
      for (size_t i = 0; i < colors.size(); ++i)
        for (int k = 0; k < 3; ++k) data[3 * i + k] = glb::srgb8_to_linear16(colors[i][k]) / 65535.0f;
      const int v = add_view(data.data(), data.size() * 4, 12, TINYGLTF_TARGET_ARRAY_BUFFER, true);
      return add_accessor(v, kFloat, false, colors.size(), TINYGLTF_TYPE_VEC3);
    }
    std::vector<std::uint16_t> data(colors.size() * 4, 0);
    for (size_t i = 0; i < colors.size(); ++i)
      for (int k = 0; k < 3; ++k) data[4 * i + k] = glb::srgb8_to_linear16(colors[i][k]);
    const int v = add_view(data.data(), data.size() * 2, 8, TINYGLTF_TARGET_ARRAY_BUFFER, true);
    return add_accessor(v, kUShort, true, colors.size(), TINYGLTF_TYPE_VEC3);
  }

  // -1 (no indices: a non-indexed primitive) when the indices are just 0, 1, 2, ... over all vertices, as in the
  // atlas mesh where every triangle has its own vertices.
  int add_indices(const std::vector<std::uint32_t>& idx, size_t vertex_count) {
    bool sequential = idx.size() == vertex_count;
    for (size_t i = 0; sequential && i < idx.size(); ++i) sequential = idx[i] == i;
    if (sequential) return -1;
    if (vertex_count <= 65535) {  // 65535 itself is the primitive-restart value, never an index
      std::vector<std::uint16_t> data(idx.begin(), idx.end());
      const int v = add_view(data.data(), data.size() * 2, 0, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER, true);
      return add_accessor(v, kUShort, false, idx.size(), TINYGLTF_TYPE_SCALAR);
    }
    const int v = add_view(idx.data(), idx.size() * 4, 0, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER, true);
    return add_accessor(v, kUInt, false, idx.size(), TINYGLTF_TYPE_SCALAR);
  }

  // uv_units_w/h > 0: TEXCOORD_0 is in 1/uv_units of the texture (KHR_texture_transform scale).
  int add_material(const std::string& name, int texture, int uv_units_w = 0, int uv_units_h = 0) {
    tinygltf::Material m;
    m.name = name;
    m.pbrMetallicRoughness.metallicFactor = 0.0;
    m.pbrMetallicRoughness.roughnessFactor = 1.0;
    if (texture >= 0) m.pbrMetallicRoughness.baseColorTexture.index = texture;
    if (texture >= 0 && uv_units_w > 0) {  // integer UVs (add_uvs)
      tinygltf::Value::Object t;
      t["scale"] =
          tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(1.0 / uv_units_w), tinygltf::Value(1.0 / uv_units_h)});
      m.pbrMetallicRoughness.baseColorTexture.extensions["KHR_texture_transform"] = tinygltf::Value(t);
    }
    m.doubleSided = true;
    m.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object());
    model_.materials.push_back(m);
    return static_cast<int>(model_.materials.size() - 1);
  }

  Result<int> add_texture(const Mesh& mesh) {
    std::vector<std::uint8_t> encoded = mesh.texture_encoded;
    std::string mime = mesh.texture_mime;
    if (!encoded.empty() && mime != "image/jpeg" && mime != "image/png")
      return invalid("texture mime must be image/jpeg or image/png");
    // compat: every texture a JPEG (some viewers read nothing else); a PNG is re-encoded from its pixels.
    if (opt_.flavor == GlbFlavor::kCompat && mime == "image/png") {
      cv::Mat bgr;
      if (mesh.texture.empty()) {
        bgr = cv::imdecode(cv::Mat(1, static_cast<int>(encoded.size()), CV_8UC1, encoded.data()), cv::IMREAD_COLOR);
        if (bgr.empty()) return invalid("texture_encoded is not a readable PNG");
      } else {
        auto b = bgr_of(mesh.texture);
        if (!b) return b.error();
        bgr = *b;
      }
      if (auto st = encode_jpeg(bgr, &encoded); !st) return st.error();
      mime = "image/jpeg";
    } else if (encoded.empty()) {
      auto bgr = bgr_of(mesh.texture);
      if (!bgr) return bgr.error();
      if (auto st = encode_jpeg(*bgr, &encoded); !st) return st.error();
      mime = "image/jpeg";
    }
    if (model_.samplers.empty()) {
      tinygltf::Sampler s;
      s.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
      s.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
      s.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
      s.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
      model_.samplers.push_back(s);
    }
    tinygltf::Image img;
    img.mimeType = mime;
    img.bufferView = add_view(encoded.data(), encoded.size(), 0, 0, false);
    model_.images.push_back(img);
    tinygltf::Texture tex;
    tex.source = static_cast<int>(model_.images.size() - 1);
    tex.sampler = 0;
    model_.textures.push_back(tex);
    return static_cast<int>(model_.textures.size() - 1);
  }

  // The texture's pixels as an OpenCV BGR image (a copy).
  static Result<cv::Mat> bgr_of(const Image& t) {
    if (t.channels != 3 && t.channels != 4) return invalid("texture must be RGB8 or RGBA8");
    if (t.data.size() != size_t(t.width) * t.height * t.channels)
      return invalid("texture size disagrees with its pixels");
    cv::Mat view(t.height, t.width, t.channels == 3 ? CV_8UC3 : CV_8UC4, const_cast<std::uint8_t*>(t.data.data()));
    cv::Mat bgr;
    cv::cvtColor(view, bgr, t.channels == 3 ? cv::COLOR_RGB2BGR : cv::COLOR_RGBA2BGR);
    return bgr;
  }

  Status encode_jpeg(const cv::Mat& bgr, std::vector<std::uint8_t>* out) const {
    if (opt_.jpeg_quality < 1 || opt_.jpeg_quality > 100) return invalid("JPEG quality must be 1..100");
    if (!cv::imencode(".jpg", bgr, *out, {cv::IMWRITE_JPEG_QUALITY, opt_.jpeg_quality, cv::IMWRITE_JPEG_OPTIMIZE, 1}))
      return make_error(ErrorCode::kInternal, "glTF export: JPEG encoding failed");
    return ok_status();
  }

  int add_mesh_node(const std::string& name, tinygltf::Primitive prim, const tinygltf::Node& dequant) {
    tinygltf::Mesh m;
    m.name = name;
    m.primitives.push_back(std::move(prim));
    model_.meshes.push_back(m);
    tinygltf::Node n = dequant;
    n.name = name;
    n.mesh = static_cast<int>(model_.meshes.size() - 1);
    model_.nodes.push_back(n);
    return static_cast<int>(model_.nodes.size() - 1);
  }

  tinygltf::Model model_;
  const GlbWriteOptions& opt_;
  size_t geometry_bytes_ = 0, texture_bytes_ = 0;
  bool uses_quantization_ = false, uses_texture_transform_ = false;
};

Status check_mesh(const Mesh& m, const std::string& name) {
  if (m.indices.size() % 3) return invalid(name + ": index count is not a multiple of 3");
  for (auto i : m.indices)
    if (i >= m.positions.size()) return invalid(name + ": index " + std::to_string(i) + " out of range");
  for (const auto& p : m.positions)
    if (!p.allFinite()) return invalid(name + ": a position is not finite");
  if (!m.uvs.empty() && m.uvs.size() != m.positions.size())
    return invalid(name + ": uvs and positions differ in count");
  for (const auto& uv : m.uvs)
    if (!uv.allFinite()) return invalid(name + ": a uv is not finite");
  if (!m.colors.empty() && m.colors.size() != m.positions.size())
    return invalid(name + ": colors and positions differ in count");
  return ok_status();
}

}  // namespace

const char* to_string(GlbFlavor flavor) { return flavor == GlbFlavor::kCompat ? "compat" : "compact"; }

const char* to_string(GeometryCodec codec) { return codec == GeometryCodec::kDraco ? "draco" : "meshopt"; }

Result<GeometryCodec> parse_geometry_codec(std::string_view name) {
  if (name == "meshopt") return GeometryCodec::kMeshopt;
  if (name == "draco") return GeometryCodec::kDraco;
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown geometry codec '" + std::string(name) +
                        "' (meshopt: EXT_meshopt_compression, the "
                        "default; draco: KHR_draco_mesh_compression, about half the geometry bytes)");
}

Result<GlbFlavor> parse_glb_flavor(std::string_view name) {
  if (name == "compact") return GlbFlavor::kCompact;
  if (name == "compat") return GlbFlavor::kCompat;
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown GLB flavor '" + std::string(name) +
                        "' (compact: meshopt + quantized, for three.js, "
                        "Babylon.js, Foxglove; compat: plain floats, for Blender, Assimp and every viewer)");
}

Result<std::vector<std::uint8_t>> encode_glb(const Scene& scene, const GlbWriteOptions& requested, GlbStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  if (scene.nodes.empty() && scene.cameras.empty()) return make_error(ErrorCode::kEmpty, "glTF export: empty scene");
  GlbWriteOptions options = requested;
  const bool draco = options.flavor == GlbFlavor::kCompact && options.geometry_codec == GeometryCodec::kDraco;
  // Draco quantizes float attributes itself (gltf/draco_buffers.h): the model is written with plain floats first.
  if (options.flavor == GlbFlavor::kCompat || draco) options.quantize = options.meshopt = false;
  ModelBuilder b(options);
  tinygltf::Node root;
  root.name = "rgbdcast_world";
  root.matrix = matrix_values(camera_to_gltf());
  bool quantized_positions = false;

  for (size_t i = 0; i < scene.nodes.size(); ++i) {
    const SceneNode& sn = scene.nodes[i];
    const std::string name = sn.name.empty() ? "node" + std::to_string(i) : sn.name;
    if (!sn.to_world.allFinite()) return invalid(name + ": to_world is not finite");
    if (auto st = check_mesh(sn.mesh, name); !st) return st.error();
    if (sn.points.colors.size() != sn.points.positions.size() && !sn.points.colors.empty())
      return invalid(name + ": point colors and positions differ in count");
    for (const auto& p : sn.points.positions)
      if (!p.allFinite()) return invalid(name + ": a point is not finite");
    tinygltf::Node group;
    group.name = name;
    if (!sn.to_world.isIdentity()) group.matrix = matrix_values(sn.to_world);

    if (sn.mesh.triangle_count() > 0) {
      const Mesh& m = sn.mesh;
      tinygltf::Primitive prim;
      prim.mode = TINYGLTF_MODE_TRIANGLES;
      tinygltf::Node dequant;
      prim.attributes["POSITION"] = b.add_positions(m.positions, &dequant);
      quantized_positions = quantized_positions || options.quantize;
      int texture = -1, tex_w = 0, tex_h = 0;
      int units_per_texel = 0;
      if (m.textured()) {
        tex_w = m.texture.width;
        tex_h = m.texture.height;
        if (m.texture.empty() && !probe_image_size(m.texture_encoded.data(), m.texture_encoded.size(), &tex_w, &tex_h))
          return invalid(name + ": texture_encoded is not a JPEG/PNG");
        prim.attributes["TEXCOORD_0"] = b.add_uvs(m.uvs, tex_w, tex_h, &units_per_texel);
        auto t = b.add_texture(m);
        if (!t) return t.error();
        texture = t.value();
      } else if (!m.colors.empty()) {
        prim.attributes["COLOR_0"] = b.add_colors(m.colors);
      }
      prim.indices = b.add_indices(m.indices, m.positions.size());
      prim.material = units_per_texel ? b.add_material(name + "_material", texture, tex_w * units_per_texel,
                                                       tex_h * units_per_texel)
                                      : b.add_material(name + "_material", texture);
      group.children.push_back(b.add_mesh_node(name + "_mesh", prim, dequant));
    }
    if (sn.points.size() > 0) {
      tinygltf::Primitive prim;
      prim.mode = TINYGLTF_MODE_POINTS;
      tinygltf::Node dequant;
      prim.attributes["POSITION"] = b.add_positions(sn.points.positions, &dequant);
      quantized_positions = quantized_positions || options.quantize;
      if (!sn.points.colors.empty()) prim.attributes["COLOR_0"] = b.add_colors(sn.points.colors);
      prim.material = b.add_material(name + "_points_material", -1);
      group.children.push_back(b.add_mesh_node(name + "_points", prim, dequant));
    }
    b.model_.nodes.push_back(group);
    root.children.push_back(static_cast<int>(b.model_.nodes.size() - 1));
  }

  for (size_t i = 0; i < scene.cameras.size(); ++i) {
    const CaptureCamera& cam = scene.cameras[i];
    const Intrinsics& k = cam.intrinsics;
    if (!(k.fx > 0 && k.fy > 0 && k.width > 0 && k.height > 0 && std::isfinite(k.cx) && std::isfinite(k.cy)))
      return invalid("camera " + std::to_string(i) + ": intrinsics need fx, fy > 0 and a size");
    if (!cam.camera_to_world.allFinite()) return invalid("camera " + std::to_string(i) + ": pose is not finite");
    tinygltf::Camera c;
    c.type = "perspective";
    c.name = "capture" + std::to_string(i);
    c.perspective.yfov = k.yfov_rad();
    c.perspective.aspectRatio = static_cast<double>(k.width) / k.height;
    c.perspective.znear = 0.05;
    c.perspective.zfar = 100.0;
    b.model_.cameras.push_back(c);
    tinygltf::Node n;
    n.name = c.name;
    n.camera = static_cast<int>(b.model_.cameras.size() - 1);
    n.matrix = matrix_values(cam.camera_to_world * camera_to_gltf());
    nlohmann::json extras = {{"rgbdcast_camera",
                              {{"fx", k.fx},
                               {"fy", k.fy},
                               {"cx", k.cx},
                               {"cy", k.cy},
                               {"width", k.width},
                               {"height", k.height},
                               {"name", k.name},
                               {"timestamp", cam.timestamp},
                               {"source", cam.source},
                               {"frame_index", cam.frame_index}}}};
    n.extras = glb::to_value(extras);
    b.model_.nodes.push_back(n);
    root.children.push_back(static_cast<int>(b.model_.nodes.size() - 1));
  }

  b.model_.nodes.push_back(root);
  tinygltf::Scene sc;
  sc.name = "rgbdcast";
  sc.nodes = {static_cast<int>(b.model_.nodes.size() - 1)};
  if (!scene.extras_json.empty()) {
    const auto j = nlohmann::json::parse(scene.extras_json, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return invalid("extras_json is not a JSON object");
    sc.extras = glb::to_value(j);
  }
  b.model_.scenes.push_back(sc);
  b.model_.defaultScene = 0;
  b.model_.extensionsUsed.push_back("KHR_materials_unlit");
  if (quantized_positions || b.uses_quantization_) {
    b.model_.extensionsUsed.push_back("KHR_mesh_quantization");
    b.model_.extensionsRequired.push_back("KHR_mesh_quantization");
  }
  if (b.uses_texture_transform_) {
    b.model_.extensionsUsed.push_back("KHR_texture_transform");
    b.model_.extensionsRequired.push_back("KHR_texture_transform");
  }

  std::ostringstream os;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&b.model_, os, false, true))
    return make_error(ErrorCode::kInternal, "glTF export: tinygltf could not serialize the model");
  const std::string s = os.str();
  std::vector<std::uint8_t> glb(s.begin(), s.end());
  size_t geometry_bytes = b.geometry_bytes_;
  if (options.meshopt) {
    auto chunks = glb::parse_glb(glb.data(), glb.size());
    if (!chunks) return make_error(ErrorCode::kInternal, "glTF export: " + chunks.error().message);
    auto packed = glb::meshopt_compress(chunks.value());
    if (!packed) return packed.error();
    glb = glb::pack_glb(packed->json, packed->bin);
    geometry_bytes = packed->bin.size() - b.texture_bytes_;  // BIN = compressed geometry + images (+ padding)
  } else if (draco) {
    auto chunks = glb::parse_glb(glb.data(), glb.size());
    if (!chunks) return make_error(ErrorCode::kInternal, "glTF export: " + chunks.error().message);
    DracoOptions d = options.draco;
    d.position_step_m = options.position_quantum_m;
    auto packed = glb::draco_compress(chunks.value(), d);
    if (!packed) return packed.error();
    glb = glb::pack_glb(packed->json, packed->bin);
    geometry_bytes = packed->bin.size() - b.texture_bytes_;
  }
  if (stats) {
    auto chunks = glb::parse_glb(glb.data(), glb.size());
    stats->geometry_bytes = geometry_bytes;
    stats->texture_bytes = b.texture_bytes_;
    stats->json_bytes = chunks ? chunks->json.size() : 0;
    stats->total_bytes = glb.size();
    stats->ms = ms_since(t0);
  }
  return glb;
}

Result<std::vector<std::uint8_t>> convert_glb(const std::uint8_t* data, size_t size, const GlbWriteOptions& options,
                                              GlbStats* stats) {
  auto scene = decode_glb(data, size);
  if (!scene) return scene.error();
  // The reader names a node after its glTF mesh node ("keyframe_0_mesh"); the writer appends the suffix again.
  for (SceneNode& n : scene->nodes)
    for (const std::string suffix : {"_mesh", "_points"})
      if (n.name.size() > suffix.size() && n.name.compare(n.name.size() - suffix.size(), suffix.size(), suffix) == 0)
        n.name.resize(n.name.size() - suffix.size());
  return encode_glb(*scene, options, stats);
}

Status write_glb_file(const Scene& scene, const std::string& path, const GlbWriteOptions& options, GlbStats* stats) {
  auto bytes = encode_glb(scene, options, stats);
  if (!bytes) return bytes.error();
  return write_file_atomically(path, bytes.value());
}

}  // namespace rgbdcast
