// create_renderer(): the one place a backend is chosen, with its reason.
#include <gtest/gtest.h>

#include "renderer/create_renderer.h"

namespace rgbdcast {
namespace {

TEST(BackendChoice, AutoPrefersVulkanAndSaysWhy) {
  auto sel = create_renderer(BackendChoice::kAuto);
  ASSERT_TRUE(sel) << sel.error().message;
  // This machine (and CI) has lavapipe: auto must take Vulkan and name the device in its reason.
  EXPECT_EQ(sel->renderer->backend(), "vulkan");
  EXPECT_NE(sel->reason.find("Vulkan device found"), std::string::npos) << sel->reason;
  EXPECT_NE(sel->reason.find(sel->renderer->device()), std::string::npos) << sel->reason;
  EXPECT_NE(sel->renderer->device().find("llvmpipe"), std::string::npos) << sel->renderer->device();
}

TEST(BackendChoice, ExplicitChoices) {
  auto gl = create_renderer(BackendChoice::kOsmesa);
  ASSERT_TRUE(gl) << gl.error().message;
  EXPECT_EQ(gl->renderer->backend(), "osmesa");
  EXPECT_EQ(gl->reason, "requested");
  EXPECT_NE(gl->renderer->device().find("llvmpipe"), std::string::npos) << gl->renderer->device();
  auto vk = create_renderer(BackendChoice::kVulkan);
  ASSERT_TRUE(vk) << vk.error().message;
  EXPECT_EQ(vk->renderer->backend(), "vulkan");
}

TEST(BackendChoice, AutoFallsBackToOsmesaWithoutVulkanDevice) {
  // Point the loader at no driver at all: auto must fall back and say why.
  const char* old = std::getenv("VK_ICD_FILENAMES");
  const std::string saved = old ? old : "";
  setenv("VK_ICD_FILENAMES", "/nonexistent/icd.json", 1);
  auto sel = create_renderer(BackendChoice::kAuto);
  if (old)
    setenv("VK_ICD_FILENAMES", saved.c_str(), 1);
  else
    unsetenv("VK_ICD_FILENAMES");
  ASSERT_TRUE(sel) << sel.error().message;
  EXPECT_EQ(sel->renderer->backend(), "osmesa");
  EXPECT_NE(sel->reason.find("no usable Vulkan device"), std::string::npos) << sel->reason;
}

TEST(BackendChoice, ParseNames) {
  EXPECT_EQ(parse_backend_choice("auto").value(), BackendChoice::kAuto);
  EXPECT_EQ(parse_backend_choice("vulkan").value(), BackendChoice::kVulkan);
  EXPECT_EQ(parse_backend_choice("osmesa").value(), BackendChoice::kOsmesa);
  auto bad = parse_backend_choice("metal");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace rgbdcast
