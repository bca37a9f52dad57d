#include "renderer/osmesa/osmesa_renderer.h"

#include <GL/osmesa.h>
#include <GL/glext.h>

#include <chrono>
#include <cstring>
#include <map>

#include "base/stopwatch.h"
#include "renderer/osmesa/gl_program.h"
#include "renderer/render_camera.h"
#include "renderer/render_scene.h"
#include "scene_frag_glsl.h"
#include "scene_vert_glsl.h"

namespace rgbdcast {
namespace {

using Clock = std::chrono::steady_clock;

struct GlNode {
  Eigen::Matrix4d to_world;
  GLuint mesh_vao = 0, mesh_vbo = 0, ibo = 0, point_vao = 0, point_vbo = 0, texture = 0;
  GLsizei index_count = 0, mesh_vertex_count = 0, point_count = 0;
  ColorSource mesh_colors = ColorSource::kVertex, point_colors = ColorSource::kVertex;
};

class OsmesaRenderer final : public Renderer {
 public:
  ~OsmesaRenderer() override;
  Status init();

  std::string backend() const override { return "osmesa"; }
  std::string device() const override { return device_; }
  Result<ResidentSceneId> upload(const Scene& scene, double* upload_ms) override;
  Status append(ResidentSceneId id, const Scene& scene, double* upload_ms) override;
  void release(ResidentSceneId id) override;
  Result<RenderResult> render_scenes(std::span<const ResidentSceneId> ids, const ViewCamera& camera,
                                     const RenderOptions& options) override;

 private:
  bool make_current() { return OSMesaMakeCurrent(ctx_, dummy_, GL_UNSIGNED_BYTE, 1, 1) == GL_TRUE; }
  void delete_nodes(std::vector<GlNode>& nodes);
  // The scene's nodes as GL objects; on failure nothing is left allocated.
  Result<std::vector<GlNode>> upload_nodes(const Scene& scene);
  Status ensure_target(int width, int height);
  GLuint vertex_array(GLuint vbo, GLuint ibo);

  OSMesaContext ctx_ = nullptr;
  unsigned char dummy_[4] = {0, 0, 0, 0};  // OSMesa needs a default buffer; we draw into fbo_
  std::string device_;
  GLuint program_ = 0, ubo_ = 0, white_ = 0;
  GLuint fbo_ = 0, color_rb_ = 0, depth_rb_ = 0;
  int target_w_ = 0, target_h_ = 0;
  bool drawn_ = false;  // the target holds a completed view (RenderOptions::keep_targets draws over it)
  std::map<ResidentSceneId, std::vector<GlNode>> scenes_;
  ResidentSceneId next_id_ = 1;
};

OsmesaRenderer::~OsmesaRenderer() {
  if (!ctx_) return;
  if (make_current()) {
    for (auto& [id, nodes] : scenes_) delete_nodes(nodes);
    glDeleteFramebuffers(1, &fbo_);
    glDeleteRenderbuffers(1, &color_rb_);
    glDeleteRenderbuffers(1, &depth_rb_);
    glDeleteTextures(1, &white_);
    glDeleteBuffers(1, &ubo_);
    glDeleteProgram(program_);
  }
  OSMesaDestroyContext(ctx_);
}

Status OsmesaRenderer::init() {
  const int attribs[] = {OSMESA_FORMAT,
                         OSMESA_RGBA,
                         OSMESA_DEPTH_BITS,
                         0,
                         OSMESA_STENCIL_BITS,
                         0,
                         OSMESA_ACCUM_BITS,
                         0,
                         OSMESA_PROFILE,
                         OSMESA_CORE_PROFILE,
                         OSMESA_CONTEXT_MAJOR_VERSION,
                         4,
                         OSMESA_CONTEXT_MINOR_VERSION,
                         5,
                         0};
  ctx_ = OSMesaCreateContextAttribs(attribs, nullptr);
  if (!ctx_) return make_error(ErrorCode::kUnavailable, "OSMesa: cannot create an OpenGL 4.5 core context");
  if (!make_current()) return make_error(ErrorCode::kUnavailable, "OSMesa: cannot make the context current");
  const char* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  const char* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  if (!version || !renderer)
    return make_error(ErrorCode::kUnavailable,
                      "OSMesa: GL calls return nothing (is libGL linked ahead of libOSMesa in this binary?)");
  device_ = renderer;
  // Same clip space as Vulkan: y down, depth 0..1 (see render_camera.h). Not exported statically by libOSMesa.
  auto clip_control = reinterpret_cast<PFNGLCLIPCONTROLPROC>(OSMesaGetProcAddress("glClipControl"));
  if (!clip_control) return make_error(ErrorCode::kUnavailable, "OSMesa: glClipControl (OpenGL 4.5) is missing");
  clip_control(GL_UPPER_LEFT, GL_ZERO_TO_ONE);

  auto program = gl::build_program(scene_vert_glsl, scene_frag_glsl);
  if (!program) return program.error();
  program_ = program.value();
  glGenBuffers(1, &ubo_);
  glBindBuffer(GL_UNIFORM_BUFFER, ubo_);
  glBufferData(GL_UNIFORM_BUFFER, sizeof(DrawParams), nullptr, GL_DYNAMIC_DRAW);
  glBindBufferBase(GL_UNIFORM_BUFFER, 0, ubo_);
  const unsigned char white[4] = {255, 255, 255, 255};
  glGenTextures(1, &white_);
  glBindTexture(GL_TEXTURE_2D, white_);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, 1, 1, 0, GL_RGBA, GL_UNSIGNED_BYTE, white);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glDisable(GL_DITHER);  // on by default in GL; goldens must be deterministic
  glDisable(GL_MULTISAMPLE);
  glEnable(GL_PROGRAM_POINT_SIZE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  if (GLenum e = glGetError(); e != GL_NO_ERROR)
    return make_error(ErrorCode::kUnavailable, "OSMesa: OpenGL setup failed (error " + std::to_string(e) + ")");
  return ok_status();
}

GLuint OsmesaRenderer::vertex_array(GLuint vbo, GLuint ibo) {
  GLuint vao = 0;
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  if (ibo) glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ibo);
  const GLsizei stride = sizeof(GpuVertex);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(offsetof(GpuVertex, position)));
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(offsetof(GpuVertex, uv)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, stride, reinterpret_cast<void*>(offsetof(GpuVertex, color)));
  glBindVertexArray(0);
  return vao;
}

static GLuint make_buffer(GLenum target, const void* data, size_t bytes) {
  GLuint b = 0;
  glGenBuffers(1, &b);
  glBindBuffer(target, b);
  glBufferData(target, static_cast<GLsizeiptr>(bytes), data, GL_STATIC_DRAW);
  return b;
}

Result<std::vector<GlNode>> OsmesaRenderer::upload_nodes(const Scene& scene) {
  auto prepared = prepare_scene(scene);
  if (!prepared) return prepared.error();
  if (!make_current()) return make_error(ErrorCode::kInternal, "OSMesa: cannot make the context current");
  std::vector<GlNode> nodes;
  for (const PreparedNode& pn : prepared->nodes) {
    GlNode n;
    n.to_world = pn.to_world;
    n.mesh_colors = pn.mesh_colors;
    n.point_colors = pn.point_colors;
    if (!pn.mesh_vertices.empty()) {
      n.mesh_vbo = make_buffer(GL_ARRAY_BUFFER, pn.mesh_vertices.data(), pn.mesh_vertices.size() * sizeof(GpuVertex));
      n.mesh_vertex_count = static_cast<GLsizei>(pn.mesh_vertices.size());
      if (!pn.indices.empty()) {
        glBindVertexArray(0);
        n.ibo = make_buffer(GL_ELEMENT_ARRAY_BUFFER, pn.indices.data(), pn.indices.size() * sizeof(std::uint32_t));
        n.index_count = static_cast<GLsizei>(pn.indices.size());
      }
      n.mesh_vao = vertex_array(n.mesh_vbo, n.ibo);
    }
    if (!pn.point_vertices.empty()) {
      n.point_vbo =
          make_buffer(GL_ARRAY_BUFFER, pn.point_vertices.data(), pn.point_vertices.size() * sizeof(GpuVertex));
      n.point_count = static_cast<GLsizei>(pn.point_vertices.size());
      n.point_vao = vertex_array(n.point_vbo, 0);
    }
    if (!pn.texture.empty()) {
      glGenTextures(1, &n.texture);
      glBindTexture(GL_TEXTURE_2D, n.texture);
      glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
      // Row 0 of the image (its top) is t = 0, as uv (0,0) = top-left in Mesh and in Vulkan.
      glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, pn.texture.width, pn.texture.height, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                   pn.texture.data.data());
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    nodes.push_back(n);
  }
  if (GLenum e = glGetError(); e != GL_NO_ERROR) {
    delete_nodes(nodes);
    return make_error(e == GL_OUT_OF_MEMORY ? ErrorCode::kInternal : ErrorCode::kInternal,
                      "OSMesa: scene upload failed (GL error " + std::to_string(e) + ")");
  }
  glFinish();
  return nodes;
}

Result<ResidentSceneId> OsmesaRenderer::upload(const Scene& scene, double* upload_ms) {
  const auto t0 = Clock::now();
  auto nodes = upload_nodes(scene);
  if (!nodes) return nodes.error();
  const ResidentSceneId id = next_id_++;
  scenes_[id] = std::move(*nodes);
  if (upload_ms) *upload_ms = ms_since(t0);
  return id;
}

Status OsmesaRenderer::append(ResidentSceneId id, const Scene& scene, double* upload_ms) {
  const auto t0 = Clock::now();
  auto it = scenes_.find(id);
  if (it == scenes_.end()) return make_error(ErrorCode::kNotFound, "no resident scene " + std::to_string(id));
  auto nodes = upload_nodes(scene);
  if (!nodes) return nodes.error();
  it->second.insert(it->second.end(), nodes->begin(), nodes->end());
  if (upload_ms) *upload_ms = ms_since(t0);
  return ok_status();
}

void OsmesaRenderer::delete_nodes(std::vector<GlNode>& nodes) {
  for (GlNode& n : nodes) {
    glDeleteVertexArrays(1, &n.mesh_vao);
    glDeleteVertexArrays(1, &n.point_vao);
    glDeleteBuffers(1, &n.mesh_vbo);
    glDeleteBuffers(1, &n.ibo);
    glDeleteBuffers(1, &n.point_vbo);
    glDeleteTextures(1, &n.texture);
  }
  nodes.clear();
}

void OsmesaRenderer::release(ResidentSceneId id) {
  auto it = scenes_.find(id);
  if (it == scenes_.end()) return;
  if (make_current()) delete_nodes(it->second);
  scenes_.erase(it);
}

Status OsmesaRenderer::ensure_target(int width, int height) {
  if (fbo_ && target_w_ == width && target_h_ == height) return ok_status();
  if (fbo_) {
    glDeleteFramebuffers(1, &fbo_);
    glDeleteRenderbuffers(1, &color_rb_);
    glDeleteRenderbuffers(1, &depth_rb_);
  }
  glGenRenderbuffers(1, &color_rb_);
  glBindRenderbuffer(GL_RENDERBUFFER, color_rb_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glGenRenderbuffers(1, &depth_rb_);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_rb_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, width, height);
  glGenFramebuffers(1, &fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_rb_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_rb_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    fbo_ = 0;
    return make_error(ErrorCode::kInternal, "OSMesa: framebuffer of " + std::to_string(width) + "x" +
                                                std::to_string(height) + " is incomplete");
  }
  target_w_ = width;
  target_h_ = height;
  return ok_status();
}

Result<RenderResult> OsmesaRenderer::render_scenes(std::span<const ResidentSceneId> ids, const ViewCamera& camera,
                                                   const RenderOptions& options) {
  std::vector<const std::vector<GlNode>*> scenes;
  for (ResidentSceneId id : ids) {
    auto it = scenes_.find(id);
    if (it == scenes_.end()) return make_error(ErrorCode::kNotFound, "no resident scene with id " + std::to_string(id));
    scenes.push_back(&it->second);
  }
  if (Status s = check_camera(camera); !s) return s.error();
  if (Status s = check_options(options); !s) return s.error();
  if (options.keep_targets && !(drawn_ && target_w_ == camera.width && target_h_ == camera.height))
    return make_error(ErrorCode::kInvalidArgument, "keep_targets: no previous view of this size to draw over");
  if (!make_current()) return make_error(ErrorCode::kInternal, "OSMesa: cannot make the context current");
  if (Status s = ensure_target(camera.width, camera.height); !s) return s.error();
  const int w = camera.width, h = camera.height;
  RenderResult result;
  drawn_ = false;  // until this view's draws have completed

  const auto t_draw = Clock::now();
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, w, h);
  glDepthMask(GL_TRUE);
  if (!options.keep_targets) {
    glClearColor(options.background[0] / 255.0f, options.background[1] / 255.0f, options.background[2] / 255.0f, 0.0f);
    glClearDepth(1.0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  }
  glUseProgram(program_);
  glBindBufferBase(GL_UNIFORM_BUFFER, 0, ubo_);
  glActiveTexture(GL_TEXTURE1);  // binding = 1 in the shaders
  const Eigen::Matrix4d clip_from_world = clip_from_camera(camera) * camera.world_to_camera();
  auto set_params = [&](const GlNode& node, ColorSource source) {
    const DrawParams p = make_draw_params(clip_from_world * node.to_world, options.point_size_px, source);
    glBufferSubData(GL_UNIFORM_BUFFER, 0, sizeof(p), &p);
    glBindTexture(GL_TEXTURE_2D, node.texture ? node.texture : white_);
  };
  glBindBuffer(GL_UNIFORM_BUFFER, ubo_);
  for (const std::vector<GlNode>* nodes : scenes)
    for (const GlNode& node : *nodes) {
      if (options.mode == RenderMode::kMesh && node.index_count > 0) {
        set_params(node, node.mesh_colors);
        glBindVertexArray(node.mesh_vao);
        glDrawElements(GL_TRIANGLES, node.index_count, GL_UNSIGNED_INT, nullptr);
        continue;
      }
      const bool own_points = node.point_count > 0;
      if (!own_points && node.mesh_vertex_count == 0) continue;
      set_params(node, own_points ? ColorSource::kVertex : node.point_colors);
      glBindVertexArray(own_points ? node.point_vao : node.mesh_vao);
      glDrawArrays(GL_POINTS, 0, own_points ? node.point_count : node.mesh_vertex_count);
    }
  glBindVertexArray(0);
  glFinish();
  result.timings.render_ms = ms_since(t_draw);
  if (GLenum e = glGetError(); e != GL_NO_ERROR)
    return make_error(ErrorCode::kInternal, "OSMesa: drawing failed (GL error " + std::to_string(e) + ")");
  drawn_ = true;
  if (!options.read_back) return result;

  // GL rows are bottom-up in memory; with GL_UPPER_LEFT the image's top is the last row: flip to top row first.
  const auto t_read = Clock::now();
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  std::vector<std::uint8_t> rows(static_cast<size_t>(w) * h * 4);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rows.data());
  result.color = Image::make(w, h, 4);
  const size_t stride = static_cast<size_t>(w) * 4;
  for (int y = 0; y < h; ++y)
    std::memcpy(result.color.data.data() + y * stride, rows.data() + (h - 1 - y) * stride, stride);
  if (options.want_depth) {
    std::vector<float> d(static_cast<size_t>(w) * h);
    glReadPixels(0, 0, w, h, GL_DEPTH_COMPONENT, GL_FLOAT, d.data());
    result.depth_m.resize(d.size());
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        result.depth_m[static_cast<size_t>(y) * w + x] =
            linear_depth_m(d[static_cast<size_t>(h - 1 - y) * w + x], camera.near_m, camera.far_m);
  }
  result.timings.readback_ms = ms_since(t_read);
  return result;
}

}  // namespace

Result<std::unique_ptr<Renderer>> create_osmesa_renderer() {
  auto r = std::make_unique<OsmesaRenderer>();
  if (Status s = r->init(); !s) return s.error();
  return std::unique_ptr<Renderer>(std::move(r));
}

}  // namespace rgbdcast
