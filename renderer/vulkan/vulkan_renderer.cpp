#include "renderer/vulkan/vulkan_renderer.h"

#include <chrono>
#include <cstdint>
#include <cstring>
#include <map>

#include "base/stopwatch.h"
#include "renderer/render_camera.h"
#include "renderer/render_scene.h"
#include "renderer/vulkan/vk_context.h"
#include "renderer/vulkan/vk_resources.h"
#include "scene_frag_spv.h"
#include "scene_vert_spv.h"

namespace rgbdcast {
namespace {

using Clock = std::chrono::steady_clock;

constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

struct ResidentNode {
  Eigen::Matrix4d to_world;
  vk::Buffer mesh_vertices, indices, point_vertices;
  uint32_t index_count = 0, mesh_vertex_count = 0, point_count = 0;
  ColorSource mesh_colors = ColorSource::kVertex, point_colors = ColorSource::kVertex;
  vk::Image2D texture;  // empty: the renderer's 1x1 white texture is bound
  VkDescriptorSet set = VK_NULL_HANDLE;
};

// Nodes and the descriptor pools their sets come from: one pool per upload or append (a mission grows by appends).
struct ResidentScene {
  VkDevice device = VK_NULL_HANDLE;
  std::vector<VkDescriptorPool> pools;
  std::vector<ResidentNode> nodes;
  ~ResidentScene() {
    nodes.clear();
    for (VkDescriptorPool pool : pools) vkDestroyDescriptorPool(device, pool, nullptr);
  }
};

struct Target {
  vk::Image2D color, depth;
  vk::Buffer color_readback, depth_readback;
  // The layouts the last render_scenes() left the images in (RenderOptions::keep_targets draws over them).
  bool drawn = false;
  VkImageLayout color_layout = VK_IMAGE_LAYOUT_UNDEFINED, depth_layout = VK_IMAGE_LAYOUT_UNDEFINED;
};

// The barrier that makes an attachment ready to draw into: from what the last view left (its content kept) or, for a
// fresh view, from nothing.
void to_attachment(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from,
                   VkImageLayout to) {
  const bool color = aspect == VK_IMAGE_ASPECT_COLOR_BIT;
  const VkPipelineStageFlags draw_stages =
      color ? VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT
            : VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
  const VkAccessFlags draw_access =
      color ? VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_READ_BIT
            : VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT;
  VkPipelineStageFlags src_stage = VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT;
  VkAccessFlags src_access = 0;
  if (from == VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL) {
    src_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
  } else if (from != VK_IMAGE_LAYOUT_UNDEFINED) {
    src_stage = draw_stages;
    src_access = color ? VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT : VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  }
  vk::image_barrier(cmd, image, aspect, from, to, src_stage, src_access, draw_stages, draw_access);
}

class VulkanRenderer final : public Renderer {
 public:
  explicit VulkanRenderer(std::unique_ptr<vk::Context> ctx) : ctx_(std::move(ctx)) {}
  ~VulkanRenderer() override;
  Status init();

  std::string backend() const override { return "vulkan"; }
  std::string device() const override { return ctx_->device_name(); }
  int validation_errors() const override { return ctx_->validation_errors(); }
  Result<ResidentSceneId> upload(const Scene& scene, double* upload_ms) override;
  Status append(ResidentSceneId id, const Scene& scene, double* upload_ms) override;
  void release(ResidentSceneId id) override { scenes_.erase(id); }
  Result<RenderResult> render_scenes(std::span<const ResidentSceneId> ids, const ViewCamera& camera,
                                     const RenderOptions& options) override;

 private:
  Result<VkPipeline> make_pipeline(VkPrimitiveTopology topology);
  // Uploads the nodes of `scene` into `into` (a fresh ResidentScene: on failure the caller drops it whole).
  Status upload_nodes(const Scene& scene, ResidentScene& into);
  Status ensure_target(int width, int height);
  void record_draws(VkCommandBuffer cmd, const std::vector<const ResidentScene*>& scenes, const ViewCamera& camera,
                    const RenderOptions& options);

  std::unique_ptr<vk::Context> ctx_;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkShaderModule vert_ = VK_NULL_HANDLE, frag_ = VK_NULL_HANDLE;
  VkPipeline triangles_ = VK_NULL_HANDLE, points_ = VK_NULL_HANDLE;
  vk::Image2D white_;
  std::map<ResidentSceneId, std::unique_ptr<ResidentScene>> scenes_;
  ResidentSceneId next_id_ = 1;
  Target target_;
};

VulkanRenderer::~VulkanRenderer() {
  VkDevice d = ctx_->device();
  vkDeviceWaitIdle(d);
  scenes_.clear();
  target_ = Target{};
  white_.reset();
  if (triangles_) vkDestroyPipeline(d, triangles_, nullptr);
  if (points_) vkDestroyPipeline(d, points_, nullptr);
  if (vert_) vkDestroyShaderModule(d, vert_, nullptr);
  if (frag_) vkDestroyShaderModule(d, frag_, nullptr);
  if (layout_) vkDestroyPipelineLayout(d, layout_, nullptr);
  if (set_layout_) vkDestroyDescriptorSetLayout(d, set_layout_, nullptr);
}

Status VulkanRenderer::init() {
  VkDevice d = ctx_->device();
  VkFormatProperties fp;
  vkGetPhysicalDeviceFormatProperties(ctx_->physical_device(), kDepthFormat, &fp);
  if (!(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT) ||
      !(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_TRANSFER_SRC_BIT))
    return make_error(ErrorCode::kUnavailable, "Vulkan: device cannot render and copy D32_SFLOAT depth");

  VkShaderModuleCreateInfo smi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smi.codeSize = sizeof(scene_vert_spv);
  smi.pCode = scene_vert_spv;
  if (VkResult r = vkCreateShaderModule(d, &smi, nullptr, &vert_); r != VK_SUCCESS)
    return vk::vk_error(r, "vkCreateShaderModule");
  smi.codeSize = sizeof(scene_frag_spv);
  smi.pCode = scene_frag_spv;
  if (VkResult r = vkCreateShaderModule(d, &smi, nullptr, &frag_); r != VK_SUCCESS)
    return vk::vk_error(r, "vkCreateShaderModule");

  VkDescriptorSetLayoutBinding binding{};
  binding.binding = 1;
  binding.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  binding.descriptorCount = 1;
  binding.stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  VkDescriptorSetLayoutCreateInfo dsl{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dsl.bindingCount = 1;
  dsl.pBindings = &binding;
  if (VkResult r = vkCreateDescriptorSetLayout(d, &dsl, nullptr, &set_layout_); r != VK_SUCCESS)
    return vk::vk_error(r, "vkCreateDescriptorSetLayout");
  VkPushConstantRange pcr{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(DrawParams)};
  VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pli.setLayoutCount = 1;
  pli.pSetLayouts = &set_layout_;
  pli.pushConstantRangeCount = 1;
  pli.pPushConstantRanges = &pcr;
  if (VkResult r = vkCreatePipelineLayout(d, &pli, nullptr, &layout_); r != VK_SUCCESS)
    return vk::vk_error(r, "vkCreatePipelineLayout");
  auto tri = make_pipeline(VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST);
  if (!tri) return tri.error();
  triangles_ = tri.value();
  auto pts = make_pipeline(VK_PRIMITIVE_TOPOLOGY_POINT_LIST);
  if (!pts) return pts.error();
  points_ = pts.value();

  Image white = Image::make(1, 1, 4);
  white.data = {255, 255, 255, 255};
  auto tex = vk::create_texture(*ctx_, white);
  if (!tex) return tex.error();
  white_ = std::move(tex.value());
  return ok_status();
}

Result<VkPipeline> VulkanRenderer::make_pipeline(VkPrimitiveTopology topology) {
  VkPipelineShaderStageCreateInfo stages[2]{};
  stages[0] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
               nullptr,
               0,
               VK_SHADER_STAGE_VERTEX_BIT,
               vert_,
               "main",
               nullptr};
  stages[1] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
               nullptr,
               0,
               VK_SHADER_STAGE_FRAGMENT_BIT,
               frag_,
               "main",
               nullptr};
  VkVertexInputBindingDescription vb{0, sizeof(GpuVertex), VK_VERTEX_INPUT_RATE_VERTEX};
  VkVertexInputAttributeDescription attrs[3] = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(GpuVertex, position)},
                                                {1, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(GpuVertex, uv)},
                                                {2, 0, VK_FORMAT_R8G8B8A8_UNORM, offsetof(GpuVertex, color)}};
  VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vi.vertexBindingDescriptionCount = 1;
  vi.pVertexBindingDescriptions = &vb;
  vi.vertexAttributeDescriptionCount = 3;
  vi.pVertexAttributeDescriptions = attrs;
  VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = topology;
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.cullMode = VK_CULL_MODE_NONE;  // captured surfaces are seen from both sides by an operator
  rs.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  rs.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  ds.depthTestEnable = VK_TRUE;
  ds.depthWriteEnable = VK_TRUE;
  ds.depthCompareOp = VK_COMPARE_OP_LESS;
  VkPipelineColorBlendAttachmentState cba{};
  cba.colorWriteMask =
      VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = 1;
  cb.pAttachments = &cba;
  VkDynamicState dyn[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dy{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dy.dynamicStateCount = 2;
  dy.pDynamicStates = dyn;
  VkPipelineRenderingCreateInfo ri{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  ri.colorAttachmentCount = 1;
  ri.pColorAttachmentFormats = &kColorFormat;
  ri.depthAttachmentFormat = kDepthFormat;
  VkGraphicsPipelineCreateInfo gp{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  gp.pNext = &ri;
  gp.stageCount = 2;
  gp.pStages = stages;
  gp.pVertexInputState = &vi;
  gp.pInputAssemblyState = &ia;
  gp.pViewportState = &vp;
  gp.pRasterizationState = &rs;
  gp.pMultisampleState = &ms;
  gp.pDepthStencilState = &ds;
  gp.pColorBlendState = &cb;
  gp.pDynamicState = &dy;
  gp.layout = layout_;
  VkPipeline pipeline = VK_NULL_HANDLE;
  if (VkResult r = vkCreateGraphicsPipelines(ctx_->device(), VK_NULL_HANDLE, 1, &gp, nullptr, &pipeline);
      r != VK_SUCCESS)
    return vk::vk_error(r, "vkCreateGraphicsPipelines");
  return pipeline;
}

Status VulkanRenderer::upload_nodes(const Scene& scene, ResidentScene& into) {
  auto prepared = prepare_scene(scene);
  if (!prepared) return prepared.error();
  ResidentScene* rs = &into;
  rs->device = ctx_->device();
  const uint32_t n = static_cast<uint32_t>(prepared->nodes.size());
  VkDescriptorPoolSize ps{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, n};
  VkDescriptorPoolCreateInfo dpi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpi.maxSets = n;
  dpi.poolSizeCount = 1;
  dpi.pPoolSizes = &ps;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(rs->device, &dpi, nullptr, &pool); r != VK_SUCCESS)
    return vk::vk_error(r, "vkCreateDescriptorPool");
  rs->pools.push_back(pool);
  for (PreparedNode& pn : prepared->nodes) {
    ResidentNode rn;
    rn.to_world = pn.to_world;
    rn.mesh_colors = pn.mesh_colors;
    rn.point_colors = pn.point_colors;
    if (!pn.mesh_vertices.empty()) {
      auto vb = vk::create_buffer(*ctx_, pn.mesh_vertices.size() * sizeof(GpuVertex), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                  pn.mesh_vertices.data());
      if (!vb) return vb.error();
      rn.mesh_vertices = std::move(vb.value());
      rn.mesh_vertex_count = static_cast<uint32_t>(pn.mesh_vertices.size());
    }
    if (!pn.indices.empty()) {
      auto ib = vk::create_buffer(*ctx_, pn.indices.size() * sizeof(uint32_t), VK_BUFFER_USAGE_INDEX_BUFFER_BIT,
                                  pn.indices.data());
      if (!ib) return ib.error();
      rn.indices = std::move(ib.value());
      rn.index_count = static_cast<uint32_t>(pn.indices.size());
    }
    if (!pn.point_vertices.empty()) {
      auto pb = vk::create_buffer(*ctx_, pn.point_vertices.size() * sizeof(GpuVertex),
                                  VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, pn.point_vertices.data());
      if (!pb) return pb.error();
      rn.point_vertices = std::move(pb.value());
      rn.point_count = static_cast<uint32_t>(pn.point_vertices.size());
    }
    if (!pn.texture.empty()) {
      auto tex = vk::create_texture(*ctx_, pn.texture);
      if (!tex) return tex.error();
      rn.texture = std::move(tex.value());
    }
    VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    ai.descriptorPool = pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &set_layout_;
    if (VkResult r = vkAllocateDescriptorSets(rs->device, &ai, &rn.set); r != VK_SUCCESS)
      return vk::vk_error(r, "vkAllocateDescriptorSets");
    const vk::Image2D& tex = rn.texture.image ? rn.texture : white_;
    VkDescriptorImageInfo dii{tex.sampler, tex.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = rn.set;
    w.dstBinding = 1;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    w.pImageInfo = &dii;
    vkUpdateDescriptorSets(rs->device, 1, &w, 0, nullptr);
    rs->nodes.push_back(std::move(rn));
  }
  return ok_status();
}

Result<ResidentSceneId> VulkanRenderer::upload(const Scene& scene, double* upload_ms) {
  const auto t0 = Clock::now();
  auto rs = std::make_unique<ResidentScene>();
  if (auto st = upload_nodes(scene, *rs); !st) return st.error();
  const ResidentSceneId id = next_id_++;
  scenes_[id] = std::move(rs);
  if (upload_ms) *upload_ms = ms_since(t0);
  return id;
}

Status VulkanRenderer::append(ResidentSceneId id, const Scene& scene, double* upload_ms) {
  const auto t0 = Clock::now();
  auto it = scenes_.find(id);
  if (it == scenes_.end()) return make_error(ErrorCode::kNotFound, "no resident scene " + std::to_string(id));
  ResidentScene added;
  if (auto st = upload_nodes(scene, added); !st) return st;
  ResidentScene& rs = *it->second;
  for (auto& node : added.nodes) rs.nodes.push_back(std::move(node));
  rs.pools.insert(rs.pools.end(), added.pools.begin(), added.pools.end());
  added.nodes.clear();
  added.pools.clear();
  if (upload_ms) *upload_ms = ms_since(t0);
  return ok_status();
}

Status VulkanRenderer::ensure_target(int width, int height) {
  if (target_.color.image && target_.color.width == width && target_.color.height == height) return ok_status();
  vkDeviceWaitIdle(ctx_->device());
  target_ = Target{};
  auto color = vk::create_attachment(*ctx_, width, height, kColorFormat,
                                     VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                     VK_IMAGE_ASPECT_COLOR_BIT);
  if (!color) return color.error();
  auto depth = vk::create_attachment(*ctx_, width, height, kDepthFormat,
                                     VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                     VK_IMAGE_ASPECT_DEPTH_BIT);
  if (!depth) return depth.error();
  const VkDeviceSize pixels = static_cast<VkDeviceSize>(width) * height;
  auto cb = vk::create_buffer(*ctx_, pixels * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (!cb) return cb.error();
  auto db = vk::create_buffer(*ctx_, pixels * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (!db) return db.error();
  target_.color = std::move(color.value());
  target_.depth = std::move(depth.value());
  target_.color_readback = std::move(cb.value());
  target_.depth_readback = std::move(db.value());
  return ok_status();
}

void VulkanRenderer::record_draws(VkCommandBuffer cmd, const std::vector<const ResidentScene*>& scenes,
                                  const ViewCamera& camera, const RenderOptions& options) {
  const Eigen::Matrix4d clip_from_world = clip_from_camera(camera) * camera.world_to_camera();
  auto draw_params = [&](const ResidentNode& node, ColorSource source) {
    const DrawParams p = make_draw_params(clip_from_world * node.to_world, options.point_size_px, source);
    vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(p), &p);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_, 0, 1, &node.set, 0, nullptr);
  };
  const VkDeviceSize zero = 0;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, triangles_);
  if (options.mode == RenderMode::kMesh)
    for (const ResidentScene* scene : scenes)
      for (const ResidentNode& node : scene->nodes) {
        if (node.index_count == 0) continue;
        draw_params(node, node.mesh_colors);
        vkCmdBindVertexBuffers(cmd, 0, 1, &node.mesh_vertices.buffer, &zero);
        vkCmdBindIndexBuffer(cmd, node.indices.buffer, 0, VK_INDEX_TYPE_UINT32);
        vkCmdDrawIndexed(cmd, node.index_count, 1, 0, 0, 0);
      }
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, points_);
  for (const ResidentScene* scene : scenes)
    for (const ResidentNode& node : scene->nodes) {
      if (options.mode == RenderMode::kMesh && node.index_count > 0) continue;
      const bool own_points = node.point_count > 0;
      if (!own_points && node.mesh_vertex_count == 0) continue;
      draw_params(node, own_points ? ColorSource::kVertex : node.point_colors);
      vkCmdBindVertexBuffers(cmd, 0, 1, own_points ? &node.point_vertices.buffer : &node.mesh_vertices.buffer, &zero);
      vkCmdDraw(cmd, own_points ? node.point_count : node.mesh_vertex_count, 1, 0, 0);
    }
}

Result<RenderResult> VulkanRenderer::render_scenes(std::span<const ResidentSceneId> ids, const ViewCamera& camera,
                                                   const RenderOptions& options) {
  std::vector<const ResidentScene*> scenes;
  for (ResidentSceneId id : ids) {
    auto it = scenes_.find(id);
    if (it == scenes_.end()) return make_error(ErrorCode::kNotFound, "no resident scene with id " + std::to_string(id));
    scenes.push_back(it->second.get());
  }
  if (Status s = check_camera(camera); !s) return s.error();
  if (Status s = check_options(options); !s) return s.error();
  if (options.keep_targets &&
      !(target_.drawn && target_.color.width == camera.width && target_.color.height == camera.height))
    return make_error(ErrorCode::kInvalidArgument, "keep_targets: no previous view of this size to draw over");
  if (Status s = ensure_target(camera.width, camera.height); !s) return s.error();
  const int w = camera.width, h = camera.height;
  const VkExtent2D extent{static_cast<uint32_t>(w), static_cast<uint32_t>(h)};
  RenderResult result;
  const bool keep = options.keep_targets;
  target_.drawn = false;  // until this view's draws have completed

  Status drawn = ctx_->submit_and_wait(
      [&](VkCommandBuffer cmd) {
        to_attachment(cmd, target_.color.image, VK_IMAGE_ASPECT_COLOR_BIT,
                      keep ? target_.color_layout : VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
        to_attachment(cmd, target_.depth.image, VK_IMAGE_ASPECT_DEPTH_BIT,
                      keep ? target_.depth_layout : VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
        VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
        ca.imageView = target_.color.view;
        ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        ca.loadOp = keep ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR;
        ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        ca.clearValue.color = {
            {options.background[0] / 255.0f, options.background[1] / 255.0f, options.background[2] / 255.0f, 0.0f}};
        VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
        da.imageView = target_.depth.view;
        da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
        da.loadOp = keep ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR;
        da.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        da.clearValue.depthStencil = {1.0f, 0};
        VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
        ri.renderArea = {{0, 0}, extent};
        ri.layerCount = 1;
        ri.colorAttachmentCount = 1;
        ri.pColorAttachments = &ca;
        ri.pDepthAttachment = &da;
        vkCmdBeginRendering(cmd, &ri);
        VkViewport vp{0.0f, 0.0f, static_cast<float>(w), static_cast<float>(h), 0.0f, 1.0f};
        VkRect2D sc{{0, 0}, extent};
        vkCmdSetViewport(cmd, 0, 1, &vp);
        vkCmdSetScissor(cmd, 0, 1, &sc);
        record_draws(cmd, scenes, camera, options);
        vkCmdEndRendering(cmd);
      },
      &result.timings.render_ms);
  if (!drawn) return drawn.error();
  target_.drawn = true;
  target_.color_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  target_.depth_layout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  if (!options.read_back) return result;

  const auto t_read = Clock::now();
  Status copied = ctx_->submit_and_wait([&](VkCommandBuffer cmd) {
    vk::image_barrier(cmd, target_.color.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                      VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                      VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                      VK_ACCESS_TRANSFER_READ_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {extent.width, extent.height, 1};
    vkCmdCopyImageToBuffer(cmd, target_.color.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           target_.color_readback.buffer, 1, &region);
    if (options.want_depth) {
      vk::image_barrier(cmd, target_.depth.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                        VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT,
                        VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                        VK_ACCESS_TRANSFER_READ_BIT);
      region.imageSubresource.aspectMask = VK_IMAGE_ASPECT_DEPTH_BIT;
      vkCmdCopyImageToBuffer(cmd, target_.depth.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                             target_.depth_readback.buffer, 1, &region);
    }
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &mb, 0, nullptr, 0,
                         nullptr);
  });
  if (!copied) {
    target_.drawn = false;
    return copied.error();
  }
  target_.color_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  if (options.want_depth) target_.depth_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  result.color = Image::make(w, h, 4);
  std::memcpy(result.color.data.data(), target_.color_readback.mapped, result.color.data.size());
  if (options.want_depth) {
    result.depth_m.resize(static_cast<size_t>(w) * h);
    const float* d = static_cast<const float*>(target_.depth_readback.mapped);
    for (size_t i = 0; i < result.depth_m.size(); ++i)
      result.depth_m[i] = linear_depth_m(d[i], camera.near_m, camera.far_m);
  }
  result.timings.readback_ms = ms_since(t_read);
  return result;
}

}  // namespace

Result<std::unique_ptr<Renderer>> create_vulkan_renderer(const RendererConfig& config) {
  auto ctx = vk::Context::create(config.vulkan_validation);
  if (!ctx) return ctx.error();
  auto r = std::make_unique<VulkanRenderer>(std::move(ctx.value()));
  if (Status s = r->init(); !s) return s.error();
  return std::unique_ptr<Renderer>(std::move(r));
}

}  // namespace rgbdcast
