#pragma once
// Buffers and images of the Vulkan backend, each owning its memory. Move-only; destroyed with their Context alive.
#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>

#include "renderer/vulkan/vk_context.h"
#include "scene/image.h"

namespace rgbdcast::vk {

// A host-visible, coherent buffer, persistently mapped (vertex/index data, staging, readback).
struct Buffer {
  VkDevice device = VK_NULL_HANDLE;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  void* mapped = nullptr;
  VkDeviceSize size = 0;

  Buffer() = default;
  Buffer(Buffer&& o) noexcept { *this = static_cast<Buffer&&>(o); }
  Buffer& operator=(Buffer&& o) noexcept;
  ~Buffer() { reset(); }
  void reset();
};

// A 2D image with its view; for textures also a sampler.
struct Image2D {
  VkDevice device = VK_NULL_HANDLE;
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkSampler sampler = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;
  int width = 0, height = 0;

  Image2D() = default;
  Image2D(Image2D&& o) noexcept { *this = static_cast<Image2D&&>(o); }
  Image2D& operator=(Image2D&& o) noexcept;
  ~Image2D() { reset(); }
  void reset();
};

// size bytes, optionally filled with data.
Result<Buffer> create_buffer(const Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage,
                             const void* data = nullptr);
// An optimal-tiling device image usable as attachment and transfer source.
Result<Image2D> create_attachment(const Context& ctx, int width, int height, VkFormat format, VkImageUsageFlags usage,
                                  VkImageAspectFlags aspect);
// An RGBA8 texture, bilinear, clamp to edge, no mipmaps, filled from rgba (4 channels) and left in
// SHADER_READ_ONLY_OPTIMAL.
Result<Image2D> create_texture(Context& ctx, const Image& rgba);

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from, VkImageLayout to,
                   VkPipelineStageFlags src_stage, VkAccessFlags src_access, VkPipelineStageFlags dst_stage,
                   VkAccessFlags dst_access);

}  // namespace rgbdcast::vk
