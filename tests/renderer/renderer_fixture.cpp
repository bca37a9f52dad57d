#include "tests/renderer/renderer_fixture.h"

namespace rgbdcast::test {

std::unique_ptr<Renderer> make_test_renderer(const std::string& backend, std::string* error) {
  RendererConfig config;
  config.vulkan_validation = true;
  auto sel = create_renderer(backend == "vulkan" ? BackendChoice::kVulkan : BackendChoice::kOsmesa, config);
  if (!sel) {
    *error = sel.error().message;
    return nullptr;
  }
  return std::move(sel->renderer);
}

void BackendTest::SetUp() {
  std::string error;
  renderer_ = make_test_renderer(GetParam(), &error);
  ASSERT_TRUE(renderer_) << GetParam() << ": " << error;
  EXPECT_EQ(renderer_->backend(), GetParam());
}

void BackendTest::TearDown() {
  if (renderer_) {
    EXPECT_EQ(renderer_->validation_errors(), 0) << "Vulkan validation errors (printed above)";
  }
  renderer_.reset();
}

}  // namespace rgbdcast::test
