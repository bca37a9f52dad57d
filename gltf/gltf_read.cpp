// decode_glb / read_glb_file: untrusted GLB bytes -> Scene. Order: strict container parse, EXT_meshopt_compression
// decode (meshopt_buffers.h), KHR_draco_mesh_compression decode (draco_buffers.h), tinygltf for the document (images
// decoded by OpenCV after a size probe), then every index and byte range this file uses is checked before it is read.
#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "base/atomic_file.h"
#include "gltf/color_space.h"
#include "gltf/document_check.h"
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "scene/image_probe.h"
#include "scene/json_nesting.h"
#include "gltf/json_value.h"
#include "gltf/meshopt_buffers.h"
#include "gltf/draco_buffers.h"

namespace rgbdcast {
namespace {

constexpr size_t kMaxGlbBytes = size_t(1) << 30;
constexpr int kMaxNodeDepth = 64;

Error bad(const std::string& what) { return make_error(ErrorCode::kInvalidInput, "GLB: " + what); }

// What one decode has spent so far, shared by the tinygltf callbacks and the traversal.
struct DecodeBudget {
  const GlbDecodeLimits* limits = nullptr;
  size_t image_pixels = 0, vertices = 0, triangles = 0, texture_bytes = 0;
};

// tinygltf image callback: the size is read from the header and charged to the budget before OpenCV decodes, into
// RGB8 without an intermediate copy.
bool load_image(tinygltf::Image* image, const int index, std::string* err, std::string*, int, int,
                const unsigned char* bytes, int size, void* user) {
  auto* budget = static_cast<DecodeBudget*>(user);
  const GlbDecodeLimits& lim = *budget->limits;
  const std::string name = "image " + std::to_string(index);
  int w = 0, h = 0;
  if (size <= 0 || !probe_image_size(bytes, static_cast<size_t>(size), &w, &h)) {
    if (err) *err += name + " is not a readable JPEG or PNG\n";
    return false;
  }
  const size_t pixels = static_cast<size_t>(w) * static_cast<size_t>(h);
  if (w > lim.max_image_side_px || h > lim.max_image_side_px || pixels > lim.max_image_pixels - budget->image_pixels) {
    if (err)
      *err += name + " is " + std::to_string(w) + "x" + std::to_string(h) + ": over the limit of " +
              std::to_string(lim.max_image_side_px) + " px per side and " + std::to_string(lim.max_image_pixels) +
              " px per file\n";
    return false;
  }
  budget->image_pixels += pixels;
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(cv::Mat(1, size, CV_8UC1, const_cast<unsigned char*>(bytes)), cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    decoded.release();
  }
  if (decoded.empty() || decoded.cols != w || decoded.rows != h) {
    if (err) *err += name + " does not decode\n";
    return false;
  }
  image->width = w;
  image->height = h;
  image->component = 3;
  image->bits = 8;
  image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  image->image.resize(pixels * 3);
  cv::Mat rgb(h, w, CV_8UC3, image->image.data());  // cvtColor writes straight into the image's storage
  cv::cvtColor(decoded, rgb, cv::COLOR_BGR2RGB);
  return true;
}

// Charges one mesh instance's vertices and triangles to the budget before any of its accessors is read.
Status charge_primitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, DecodeBudget* budget) {
  auto count = [&](int index) -> size_t {
    return index >= 0 && static_cast<size_t>(index) < model.accessors.size() ? model.accessors[index].count : 0;
  };
  auto pos = prim.attributes.find("POSITION");
  const size_t vertices = pos == prim.attributes.end() ? 0 : count(pos->second);
  const size_t triangles =
      prim.mode == TINYGLTF_MODE_POINTS ? 0 : (prim.indices >= 0 ? count(prim.indices) : vertices) / 3;
  const GlbDecodeLimits& lim = *budget->limits;
  if (vertices > lim.max_vertices - budget->vertices)
    return bad("over the limit of " + std::to_string(lim.max_vertices) + " vertices per scene");
  if (triangles > lim.max_triangles - budget->triangles)
    return bad("over the limit of " + std::to_string(lim.max_triangles) + " triangles per scene");
  budget->vertices += vertices;
  budget->triangles += triangles;
  return ok_status();
}

Eigen::Matrix4d node_matrix(const tinygltf::Node& n) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (n.matrix.size() == 16) {
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m(r, c) = n.matrix[c * 4 + r];
    return m;
  }
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity(), r = Eigen::Matrix4d::Identity(), s = Eigen::Matrix4d::Identity();
  if (n.translation.size() == 3)
    t.block<3, 1>(0, 3) = Eigen::Vector3d(n.translation[0], n.translation[1], n.translation[2]);
  if (n.rotation.size() == 4) {
    Eigen::Quaterniond q(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);
    if (q.norm() > 1e-12) r.block<3, 3>(0, 0) = q.normalized().toRotationMatrix();
  }
  if (n.scale.size() == 3) s.diagonal().head<3>() = Eigen::Vector3d(n.scale[0], n.scale[1], n.scale[2]);
  return t * r * s;
}

// Reads an accessor as `ncomp` doubles per element, applying glTF's normalization rules.
Status read_accessor(const tinygltf::Model& model, int index, int ncomp, std::vector<double>* out,
                     const std::string& what) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size())
    return bad(what + ": accessor index out of range");
  const tinygltf::Accessor& a = model.accessors[index];
  if (a.sparse.isSparse) return bad(what + ": sparse accessors are not supported");
  const int comps = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type));
  const int csize = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(a.componentType));
  if (comps != ncomp)
    return bad(what + ": accessor has " + std::to_string(comps) + " components, expected " + std::to_string(ncomp));
  if (csize <= 0) return bad(what + ": bad component type");
  if (a.count == 0) {
    out->clear();
    return ok_status();
  }
  if (a.bufferView < 0) return bad(what + ": accessor without bufferView");  // check_document refuses them too
  if (static_cast<size_t>(a.bufferView) >= model.bufferViews.size())
    return bad(what + ": bufferView index out of range");
  const tinygltf::BufferView& v = model.bufferViews[a.bufferView];
  if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= model.buffers.size())
    return bad(what + ": buffer index out of range");
  const auto& data = model.buffers[v.buffer].data;
  const size_t elem = static_cast<size_t>(comps) * csize;
  const size_t stride = v.byteStride ? v.byteStride : elem;
  if (stride < elem) return bad(what + ": byteStride smaller than an element");
  if (v.byteOffset > data.size() || v.byteLength > data.size() - v.byteOffset)
    return bad(what + ": bufferView past its buffer");
  if (a.byteOffset > v.byteLength) return bad(what + ": accessor offset past its bufferView");
  const size_t room = v.byteLength - a.byteOffset;
  if (elem > room || (a.count - 1) > (room - elem) / stride) return bad(what + ": accessor runs past its bufferView");
  const std::uint8_t* base = data.data() + v.byteOffset + a.byteOffset;
  out->assign(a.count * ncomp, 0.0);  // only now: the bytes for every element are present
  for (size_t i = 0; i < a.count; ++i) {
    const std::uint8_t* e = base + i * stride;
    for (int k = 0; k < ncomp; ++k) {
      const std::uint8_t* p = e + k * csize;
      double x = 0;
      switch (a.componentType) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
          std::int8_t t;
          std::memcpy(&t, p, 1);
          x = a.normalized ? std::max(t / 127.0, -1.0) : t;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
          x = a.normalized ? p[0] / 255.0 : p[0];
          break;
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
          std::int16_t t;
          std::memcpy(&t, p, 2);
          x = a.normalized ? std::max(t / 32767.0, -1.0) : t;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
          std::uint16_t t;
          std::memcpy(&t, p, 2);
          x = a.normalized ? t / 65535.0 : t;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
          std::uint32_t t;
          std::memcpy(&t, p, 4);
          x = t;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_FLOAT: {
          float t;
          std::memcpy(&t, p, 4);
          x = t;
          break;
        }
        default:
          return bad(what + ": unsupported component type");
      }
      (*out)[i * ncomp + k] = x;
    }
  }
  return ok_status();
}

Status read_positions(const tinygltf::Model& model, int index, std::vector<Eigen::Vector3f>* out) {
  std::vector<double> v;
  if (auto st = read_accessor(model, index, 3, &v, "POSITION"); !st) return st;
  out->resize(v.size() / 3);
  for (size_t i = 0; i < out->size(); ++i) {
    (*out)[i] = Eigen::Vector3f(float(v[3 * i]), float(v[3 * i + 1]), float(v[3 * i + 2]));
    if (!(*out)[i].allFinite()) return bad("POSITION has a non-finite value");
  }
  return ok_status();
}

Status read_colors(const tinygltf::Model& model, int index, size_t n, std::vector<Rgb8>* out) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) return bad("COLOR_0 accessor out of range");
  const int ncomp = model.accessors[index].type == TINYGLTF_TYPE_VEC4 ? 4 : 3;
  const bool is_float = model.accessors[index].componentType == TINYGLTF_COMPONENT_TYPE_FLOAT;
  const bool norm = model.accessors[index].normalized;
  if (!is_float && !norm) return bad("COLOR_0 integers must be normalized");
  std::vector<double> v;
  if (auto st = read_accessor(model, index, ncomp, &v, "COLOR_0"); !st) return st;
  if (v.size() / ncomp != n) return bad("COLOR_0 count differs from POSITION");
  out->resize(n);
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) (*out)[i][k] = glb::linear_to_srgb8(v[i * ncomp + k]);
  return ok_status();
}

// KHR_texture_transform on a texture reference: uv' = T(offset) R(rotation) S(scale) uv (the extension's matrix).
Eigen::Matrix3d texture_transform(const tinygltf::TextureInfo& info) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  auto it = info.extensions.find("KHR_texture_transform");
  if (it == info.extensions.end() || !it->second.IsObject()) return m;
  const nlohmann::json t = glb::to_json(it->second);
  auto pair = [&](const char* key, double d0, double d1) -> Eigen::Vector2d {
    if (t.contains(key) && t[key].is_array() && t[key].size() == 2 && t[key][0].is_number() && t[key][1].is_number())
      return {t[key][0].get<double>(), t[key][1].get<double>()};
    return {d0, d1};
  };
  const Eigen::Vector2d offset = pair("offset", 0, 0), scale = pair("scale", 1, 1);
  const double r = t.contains("rotation") && t["rotation"].is_number() ? t["rotation"].get<double>() : 0.0;
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity(), R = Eigen::Matrix3d::Identity(), S = Eigen::Matrix3d::Identity();
  T(0, 2) = offset.x();
  T(1, 2) = offset.y();
  R << std::cos(r), std::sin(r), 0, -std::sin(r), std::cos(r), 0, 0, 0, 1;
  S(0, 0) = scale.x();
  S(1, 1) = scale.y();
  m = T * R * S;
  return m.allFinite() ? m : Eigen::Matrix3d::Identity();
}

Status read_texture(const tinygltf::Model& model, int material, Mesh* mesh, int* texcoord,
                    Eigen::Matrix3d* uv_transform, DecodeBudget* budget) {
  *texcoord = -1;
  *uv_transform = Eigen::Matrix3d::Identity();
  if (material < 0) return ok_status();
  if (static_cast<size_t>(material) >= model.materials.size()) return bad("material index out of range");
  const auto& info = model.materials[material].pbrMetallicRoughness.baseColorTexture;
  if (info.index < 0) return ok_status();
  if (static_cast<size_t>(info.index) >= model.textures.size()) return bad("texture index out of range");
  const int source = model.textures[info.index].source;
  if (source < 0 || static_cast<size_t>(source) >= model.images.size()) return bad("image index out of range");
  const tinygltf::Image& img = model.images[source];
  if (img.component != 3 || img.bits != 8 || img.width <= 0 || img.height <= 0 ||
      img.image.size() != static_cast<size_t>(img.width) * img.height * 3)
    return bad("image " + std::to_string(source) + " was not decoded");
  size_t encoded_bytes = 0;
  if (img.bufferView >= 0 && static_cast<size_t>(img.bufferView) < model.bufferViews.size())
    encoded_bytes = model.bufferViews[img.bufferView].byteLength;
  // Each mesh instance holds its own copy of its texture: charged before copying.
  const size_t cost = img.image.size() + encoded_bytes;
  if (cost > budget->limits->max_scene_texture_bytes - budget->texture_bytes)
    return bad("textures over the limit of " + std::to_string(budget->limits->max_scene_texture_bytes >> 20) +
               " MiB per scene (counted per mesh instance)");
  budget->texture_bytes += cost;
  mesh->texture.width = img.width;
  mesh->texture.height = img.height;
  mesh->texture.channels = 3;
  mesh->texture.data = img.image;
  if (img.bufferView >= 0 && static_cast<size_t>(img.bufferView) < model.bufferViews.size()) {
    const auto& v = model.bufferViews[img.bufferView];
    if (v.buffer >= 0 && static_cast<size_t>(v.buffer) < model.buffers.size()) {
      const auto& d = model.buffers[v.buffer].data;
      if (v.byteOffset <= d.size() && v.byteLength <= d.size() - v.byteOffset) {
        mesh->texture_encoded.assign(d.begin() + v.byteOffset, d.begin() + v.byteOffset + v.byteLength);
        mesh->texture_mime = img.mimeType;
      }
    }
  }
  if (info.texCoord < 0 || info.texCoord > 7) return bad("texCoord set out of range");
  *texcoord = info.texCoord;
  *uv_transform = texture_transform(info);
  return ok_status();
}

Status read_primitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, SceneNode* out,
                      DecodeBudget* budget) {
  auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) return bad("primitive without POSITION");
  std::vector<Eigen::Vector3f> positions;
  if (auto st = read_positions(model, pos_it->second, &positions); !st) return st;
  std::vector<Rgb8> colors;
  if (auto c = prim.attributes.find("COLOR_0"); c != prim.attributes.end())
    if (auto st = read_colors(model, c->second, positions.size(), &colors); !st) return st;
  if (prim.mode == TINYGLTF_MODE_POINTS) {
    out->points.positions = std::move(positions);
    out->points.colors = std::move(colors);
    return ok_status();
  }
  if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1)
    return bad("primitive mode " + std::to_string(prim.mode) + " is not supported (triangles or points only)");
  Mesh& m = out->mesh;
  m.positions = std::move(positions);
  m.colors = std::move(colors);
  if (prim.indices >= 0) {
    std::vector<double> idx;
    if (auto st = read_accessor(model, prim.indices, 1, &idx, "indices"); !st) return st;
    if (idx.size() % 3) return bad("index count is not a multiple of 3");
    m.indices.resize(idx.size());
    for (size_t i = 0; i < idx.size(); ++i) {
      if (!(idx[i] >= 0 && idx[i] < static_cast<double>(m.positions.size()))) return bad("index out of range");
      m.indices[i] = static_cast<std::uint32_t>(idx[i]);
    }
  } else {
    if (m.positions.size() % 3) return bad("non-indexed triangles need a multiple of 3 vertices");
    m.indices.resize(m.positions.size());
    for (size_t i = 0; i < m.indices.size(); ++i) m.indices[i] = static_cast<std::uint32_t>(i);
  }
  int texcoord = -1;
  Eigen::Matrix3d uv_transform;
  if (auto st = read_texture(model, prim.material, &m, &texcoord, &uv_transform, budget); !st) return st;
  if (texcoord >= 0) {
    auto uv_it = prim.attributes.find("TEXCOORD_" + std::to_string(texcoord));
    if (uv_it == prim.attributes.end()) return bad("textured primitive without TEXCOORD_" + std::to_string(texcoord));
    std::vector<double> uv;
    if (auto st = read_accessor(model, uv_it->second, 2, &uv, "TEXCOORD"); !st) return st;
    if (uv.size() / 2 != m.positions.size()) return bad("TEXCOORD count differs from POSITION");
    m.uvs.resize(m.positions.size());
    for (size_t i = 0; i < m.uvs.size(); ++i)
      m.uvs[i] = (uv_transform * Eigen::Vector3d(uv[2 * i], uv[2 * i + 1], 1.0)).head<2>().cast<float>();
  }
  return ok_status();
}

CaptureCamera read_camera(const tinygltf::Model& model, const tinygltf::Node& node, const Eigen::Matrix4d& world) {
  CaptureCamera cam;
  const Eigen::Matrix4d C = camera_to_gltf();
  cam.camera_to_world = C * world * C;
  const tinygltf::Camera& c = model.cameras[node.camera];
  Intrinsics& k = cam.intrinsics;
  if (c.type == "perspective" && c.perspective.yfov > 0 && c.perspective.yfov < M_PI) {
    const double a = c.perspective.aspectRatio;
    const double aspect = a >= 1.0 / 16 && a <= 16 ? a : 4.0 / 3.0;  // keeps the width within kMaxImageSize
    k.height = 480;
    k.width = std::max(1, static_cast<int>(std::lround(480 * aspect)));
    k.fy = 0.5 * k.height / std::tan(0.5 * c.perspective.yfov);
    k.fx = k.fy;
    k.cx = 0.5 * k.width - 0.5;
    k.cy = 0.5 * k.height - 0.5;
  }
  const nlohmann::json extras = glb::to_json(node.extras);
  if (extras.is_object() && extras.contains("rgbdcast_camera") && extras["rgbdcast_camera"].is_object()) {
    const auto& e = extras["rgbdcast_camera"];
    auto num = [&](const char* key, double fallback) {
      return e.contains(key) && e[key].is_number() ? e[key].get<double>() : fallback;
    };
    // An untrusted file's intrinsics are taken only when they make a camera (fx, fy > 0, all finite); otherwise the
    // glTF camera's own (or the default) stays, so a view at pose=capture never gets a degenerate projection.
    const double fx = num("fx", k.fx), fy = num("fy", k.fy), cx = num("cx", k.cx), cy = num("cy", k.cy);
    if (std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy) && fx > 0 && fy > 0)
      k.fx = fx, k.fy = fy, k.cx = cx, k.cy = cy;
    const double w = num("width", k.width), h = num("height", k.height);
    if (w >= 1 && w <= kMaxImageSize && h >= 1 && h <= kMaxImageSize) k.width = int(w), k.height = int(h);
    if (e.contains("name") && e["name"].is_string()) k.name = e["name"].get<std::string>();
    if (const double t = num("timestamp", 0.0); std::isfinite(t)) cam.timestamp = t;
    if (e.contains("source") && e["source"].is_string()) cam.source = e["source"].get<std::string>();
    const double fi = num("frame_index", -1);
    if (fi >= -1 && fi <= 2147483647.0) cam.frame_index = static_cast<int>(fi);
  }
  return cam;
}

// KHR_mesh_quantization files keep integer positions and put the dequantization (translation + scale) on the
// mesh's node. When a node holding integer positions has only translation and scale (no rotation, no matrix), that
// transform is applied to the positions here, so that positions are metres in the node's parent frame and to_world
// stays the placement (rigid for rgbdcast files) rather than a scale into integer units.
void bake_dequantization(const tinygltf::Model& model, const tinygltf::Node& node, const tinygltf::Primitive& prim,
                         const Eigen::Matrix4d& parent_to_world, SceneNode* sn) {
  auto pos = prim.attributes.find("POSITION");
  if (pos == prim.attributes.end() || pos->second < 0 || static_cast<size_t>(pos->second) >= model.accessors.size())
    return;
  if (model.accessors[pos->second].componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) return;
  if (node.matrix.size() == 16 || node.rotation.size() == 4) return;
  const Eigen::Matrix4d local = node_matrix(node);
  auto apply = [&](std::vector<Eigen::Vector3f>& ps) {
    for (auto& p : ps) p = (local * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0)).head<3>().cast<float>();
  };
  apply(sn->mesh.positions);
  apply(sn->points.positions);
  sn->to_world = parent_to_world;
}

// tinygltf file-system callbacks that refuse everything: check_document has already refused every URI, and this
// keeps tinygltf from opening a file even if a path through it were missed.
bool no_file_exists(const std::string&, void*) { return false; }
std::string no_expand(const std::string&, void*) { return std::string(); }
bool no_read(std::vector<unsigned char>*, std::string* err, const std::string&, void*) {
  if (err) *err = "external URI not allowed";
  return false;
}
bool no_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err = "writing files is not allowed";
  return false;
}

// tinygltf's errors, as one line. They may quote the document's own strings, never a path of this machine (the
// callbacks above see no file).
std::string one_line(std::string err) {
  while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
  for (auto& ch : err)
    if (ch == '\n' || ch == '\r') ch = ';';
  if (err.size() > 300) err = err.substr(0, 300) + "...";
  return err;
}

}  // namespace

Result<Scene> decode_glb(const std::uint8_t* data, size_t size, const GlbDecodeLimits& limits) {
  if (size > kMaxGlbBytes) return bad("larger than 1 GiB");
  auto chunks = glb::parse_glb(data, size);
  if (!chunks) return chunks.error();
  // The nesting guard runs before any JSON parser (tinygltf's recursion overflows the stack on deep extras).
  if (auto st = check_json_nesting(chunks->json, limits.max_json_bytes, limits.max_json_depth, "GLB"); !st)
    return st.error();
  // A plain file goes to tinygltf as it came; a meshopt one is decoded into a plain one first.
  std::vector<std::uint8_t> repacked;
  const std::uint8_t* bytes = data;
  size_t nbytes = size;
  const glb::GlbChunks* plain = &chunks.value();
  Result<glb::GlbChunks> decompressed = glb::GlbChunks{};
  if (glb::uses_meshopt(*chunks)) {
    decompressed = glb::meshopt_decompress(*chunks, limits.max_meshopt_bytes);
    if (!decompressed) return decompressed.error();
    plain = &decompressed.value();
  }
  Result<glb::GlbChunks> undraco = glb::GlbChunks{};
  if (glb::uses_draco(*plain)) {
    undraco = glb::draco_decompress(*plain, limits);
    if (!undraco) return undraco.error();
    plain = &undraco.value();
  }
  if (plain != &chunks.value()) {
    repacked = glb::pack_glb(plain->json, plain->bin);
    bytes = repacked.data();
    nbytes = repacked.size();
  }
  if (nbytes > std::numeric_limits<unsigned int>::max()) return bad("too large");
  {
    const nlohmann::json doc = nlohmann::json::parse(plain->json, nullptr, /*allow_exceptions=*/false);
    if (doc.is_discarded()) return bad("the JSON chunk is not valid JSON");
    if (auto st = glb::check_document(doc, plain->bin.size()); !st) return st.error();
  }

  tinygltf::Model model;
  std::string err, warn;
  bool loaded = false;
  DecodeBudget budget;
  budget.limits = &limits;
  try {
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(load_image, &budget);
    loader.SetFsCallbacks(tinygltf::FsCallbacks{no_file_exists, no_expand, no_read, no_write, nullptr});
    loaded = loader.LoadBinaryFromMemory(&model, &err, &warn, bytes, static_cast<unsigned int>(nbytes));
  } catch (const std::exception& e) {
    err = e.what();
  }
  if (!loaded) return bad(err.empty() ? "tinygltf could not parse the document" : one_line(err));
  for (const auto& r : model.extensionsRequired)
    if (r != "KHR_mesh_quantization" && r != "KHR_materials_unlit" && r != "KHR_texture_transform")
      return make_error(ErrorCode::kInvalidInput, "GLB: requires unsupported extension " + r);

  Scene scene;
  std::vector<int> roots;
  const int sc = model.defaultScene >= 0 ? model.defaultScene : 0;
  if (static_cast<size_t>(sc) < model.scenes.size()) {
    roots = model.scenes[sc].nodes;
    if (model.scenes[sc].extras.Type() != tinygltf::NULL_TYPE)
      scene.extras_json = glb::to_json(model.scenes[sc].extras).dump();
  } else {
    std::set<int> children;
    for (const auto& n : model.nodes) children.insert(n.children.begin(), n.children.end());
    for (int i = 0; i < static_cast<int>(model.nodes.size()); ++i)
      if (!children.count(i)) roots.push_back(i);
  }
  const Eigen::Matrix4d C = camera_to_gltf();
  std::vector<char> visiting(model.nodes.size(), 0);
  std::function<Status(int, const Eigen::Matrix4d&, int)> visit = [&](int index, const Eigen::Matrix4d& parent,
                                                                      int depth) -> Status {
    if (index < 0 || static_cast<size_t>(index) >= model.nodes.size()) return bad("node index out of range");
    if (depth > kMaxNodeDepth) return bad("node hierarchy deeper than " + std::to_string(kMaxNodeDepth));
    if (visiting[index]) return bad("node " + std::to_string(index) + " appears twice in the hierarchy");
    visiting[index] = 1;
    const tinygltf::Node& node = model.nodes[index];
    const Eigen::Matrix4d world = parent * node_matrix(node);
    if (!world.allFinite()) return bad("node " + std::to_string(index) + " has a non-finite transform");
    if (node.mesh >= 0) {
      if (static_cast<size_t>(node.mesh) >= model.meshes.size()) return bad("mesh index out of range");
      const auto& mesh = model.meshes[node.mesh];
      for (size_t p = 0; p < mesh.primitives.size(); ++p) {
        SceneNode sn;
        sn.name = node.name.empty() ? (mesh.name.empty() ? "mesh" + std::to_string(node.mesh) : mesh.name) : node.name;
        if (mesh.primitives.size() > 1) sn.name += "#" + std::to_string(p);
        sn.to_world = C * world;
        if (auto st = charge_primitive(model, mesh.primitives[p], &budget); !st) return st;
        if (auto st = read_primitive(model, mesh.primitives[p], &sn, &budget); !st) return st;
        bake_dequantization(model, node, mesh.primitives[p], C * parent, &sn);
        scene.nodes.push_back(std::move(sn));
      }
    }
    if (node.camera >= 0) {
      if (static_cast<size_t>(node.camera) >= model.cameras.size()) return bad("camera index out of range");
      scene.cameras.push_back(read_camera(model, node, world));
    }
    for (int child : node.children)
      if (auto st = visit(child, world, depth + 1); !st) return st;
    return ok_status();
  };
  try {
    for (int r : roots)
      if (auto st = visit(r, Eigen::Matrix4d::Identity(), 0); !st) return st.error();
  } catch (const std::exception& e) {
    return bad(std::string("malformed document: ") + e.what());
  }
  if (scene.nodes.empty() && scene.cameras.empty())
    return make_error(ErrorCode::kEmpty, "GLB: no mesh, points or camera");
  return scene;
}

Result<Scene> read_glb_file(const std::string& path, const GlbDecodeLimits& limits) {
  auto bytes = read_file_bytes(path, kMaxGlbBytes);
  if (!bytes) return bytes.error();
  auto scene = decode_glb(bytes->data(), bytes->size(), limits);
  if (!scene) return make_error(scene.error().code, path + ": " + scene.error().message);
  return scene;
}

}  // namespace rgbdcast
