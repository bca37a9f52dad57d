// The validation counter that every Vulkan test relies on really counts: a deliberately invalid call is seen.
#include <gtest/gtest.h>

#include "renderer/vulkan/vk_context.h"

namespace rgbdcast {
namespace {

TEST(VulkanValidation, MessengerCountsErrors) {
  auto ctx = vk::Context::create(/*validation=*/true);
  ASSERT_TRUE(ctx) << ctx.error().message;
  EXPECT_EQ(ctx.value()->validation_errors(), 0);
  // size 0 is invalid (VUID-VkBufferCreateInfo-size-00912); the layer reports it and lavapipe copes.
  VkBufferCreateInfo bci{};
  bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  bci.size = 0;
  bci.usage = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT;
  VkBuffer buffer = VK_NULL_HANDLE;
  testing::internal::CaptureStderr();
  vkCreateBuffer(ctx.value()->device(), &bci, nullptr, &buffer);
  const std::string printed = testing::internal::GetCapturedStderr();
  if (buffer) vkDestroyBuffer(ctx.value()->device(), buffer, nullptr);
  EXPECT_GE(ctx.value()->validation_errors(), 1);
  EXPECT_NE(printed.find("Vulkan validation error"), std::string::npos) << printed;
}

}  // namespace
}  // namespace rgbdcast
