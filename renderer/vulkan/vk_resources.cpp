#include "renderer/vulkan/vk_resources.h"

#include <cstring>
#include <utility>

namespace rgbdcast::vk {

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    reset();
    device = std::exchange(o.device, VK_NULL_HANDLE);
    buffer = std::exchange(o.buffer, VK_NULL_HANDLE);
    memory = std::exchange(o.memory, VK_NULL_HANDLE);
    mapped = std::exchange(o.mapped, nullptr);
    size = std::exchange(o.size, 0);
  }
  return *this;
}

void Buffer::reset() {
  if (!device) return;
  if (buffer) vkDestroyBuffer(device, buffer, nullptr);
  if (memory) vkFreeMemory(device, memory, nullptr);  // unmaps implicitly
  device = VK_NULL_HANDLE;
  buffer = VK_NULL_HANDLE;
  memory = VK_NULL_HANDLE;
  mapped = nullptr;
  size = 0;
}

Image2D& Image2D::operator=(Image2D&& o) noexcept {
  if (this != &o) {
    reset();
    device = std::exchange(o.device, VK_NULL_HANDLE);
    image = std::exchange(o.image, VK_NULL_HANDLE);
    memory = std::exchange(o.memory, VK_NULL_HANDLE);
    view = std::exchange(o.view, VK_NULL_HANDLE);
    sampler = std::exchange(o.sampler, VK_NULL_HANDLE);
    format = o.format;
    width = o.width;
    height = o.height;
  }
  return *this;
}

void Image2D::reset() {
  if (!device) return;
  if (sampler) vkDestroySampler(device, sampler, nullptr);
  if (view) vkDestroyImageView(device, view, nullptr);
  if (image) vkDestroyImage(device, image, nullptr);
  if (memory) vkFreeMemory(device, memory, nullptr);
  device = VK_NULL_HANDLE;
  image = VK_NULL_HANDLE;
  memory = VK_NULL_HANDLE;
  view = VK_NULL_HANDLE;
  sampler = VK_NULL_HANDLE;
}

Result<Buffer> create_buffer(const Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage, const void* data) {
  Buffer b;
  b.device = ctx.device();
  b.size = size;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = size > 0 ? size : 4;
  bci.usage = usage;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  if (VkResult r = vkCreateBuffer(b.device, &bci, nullptr, &b.buffer); r != VK_SUCCESS)
    return vk_error(r, "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(b.device, b.buffer, &req);
  const int type = ctx.find_memory_type(req.memoryTypeBits,
                                        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  if (type < 0) return make_error(ErrorCode::kUnavailable, "Vulkan: no host-visible coherent memory type");
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = static_cast<uint32_t>(type);
  if (VkResult r = vkAllocateMemory(b.device, &mai, nullptr, &b.memory); r != VK_SUCCESS)
    return vk_error(r, "vkAllocateMemory (buffer)");
  if (VkResult r = vkBindBufferMemory(b.device, b.buffer, b.memory, 0); r != VK_SUCCESS)
    return vk_error(r, "vkBindBufferMemory");
  if (VkResult r = vkMapMemory(b.device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped); r != VK_SUCCESS)
    return vk_error(r, "vkMapMemory");
  if (data && size > 0) std::memcpy(b.mapped, data, size);
  return b;
}

static Result<Image2D> create_image(const Context& ctx, int width, int height, VkFormat format, VkImageUsageFlags usage,
                                    VkImageAspectFlags aspect) {
  Image2D im;
  im.device = ctx.device();
  im.format = format;
  im.width = width;
  im.height = height;
  VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = format;
  ici.extent = {static_cast<uint32_t>(width), static_cast<uint32_t>(height), 1};
  ici.mipLevels = 1;
  ici.arrayLayers = 1;
  ici.samples = VK_SAMPLE_COUNT_1_BIT;  // no MSAA: deterministic goldens
  ici.tiling = VK_IMAGE_TILING_OPTIMAL;
  ici.usage = usage;
  ici.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ici.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  if (VkResult r = vkCreateImage(im.device, &ici, nullptr, &im.image); r != VK_SUCCESS)
    return vk_error(r, "vkCreateImage");
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(im.device, im.image, &req);
  int type = ctx.find_memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (type < 0) type = ctx.find_memory_type(req.memoryTypeBits, 0);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = static_cast<uint32_t>(type);
  if (VkResult r = vkAllocateMemory(im.device, &mai, nullptr, &im.memory); r != VK_SUCCESS)
    return vk_error(r, "vkAllocateMemory (image)");
  if (VkResult r = vkBindImageMemory(im.device, im.image, im.memory, 0); r != VK_SUCCESS)
    return vk_error(r, "vkBindImageMemory");
  VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vci.image = im.image;
  vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vci.format = format;
  vci.subresourceRange = {aspect, 0, 1, 0, 1};
  if (VkResult r = vkCreateImageView(im.device, &vci, nullptr, &im.view); r != VK_SUCCESS)
    return vk_error(r, "vkCreateImageView");
  return im;
}

Result<Image2D> create_attachment(const Context& ctx, int width, int height, VkFormat format, VkImageUsageFlags usage,
                                  VkImageAspectFlags aspect) {
  return create_image(ctx, width, height, format, usage, aspect);
}

Result<Image2D> create_texture(Context& ctx, const Image& rgba) {
  auto im = create_image(ctx, rgba.width, rgba.height, VK_FORMAT_R8G8B8A8_UNORM,
                         VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, VK_IMAGE_ASPECT_COLOR_BIT);
  if (!im) return im.error();
  auto staging = create_buffer(ctx, rgba.data.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, rgba.data.data());
  if (!staging) return staging.error();
  VkImage image = im->image;
  VkBuffer src = staging->buffer;
  const uint32_t w = static_cast<uint32_t>(rgba.width), h = static_cast<uint32_t>(rgba.height);
  Status s = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    image_barrier(cmd, image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {w, h, 1};
    vkCmdCopyBufferToImage(cmd, src, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    image_barrier(
        cmd, image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
        VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
  });
  if (!s) return s.error();
  VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  sci.magFilter = VK_FILTER_LINEAR;
  sci.minFilter = VK_FILTER_LINEAR;
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sci.maxLod = 0.0f;
  if (VkResult r = vkCreateSampler(im->device, &sci, nullptr, &im->sampler); r != VK_SUCCESS)
    return vk_error(r, "vkCreateSampler");
  return im;
}

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from, VkImageLayout to,
                   VkPipelineStageFlags src_stage, VkAccessFlags src_access, VkPipelineStageFlags dst_stage,
                   VkAccessFlags dst_access) {
  VkImageMemoryBarrier b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  b.srcAccessMask = src_access;
  b.dstAccessMask = dst_access;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {aspect, 0, 1, 0, 1};
  vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 0, nullptr, 0, nullptr, 1, &b);
}

}  // namespace rgbdcast::vk
