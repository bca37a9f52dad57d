#include "tests/renderer/renderer_fixture.h"

#include "renderer/create_renderer.h"
#include "tests/renderer/image_compare.h"

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

void expect_matches_golden(Renderer& renderer, ResidentSceneId id, const ViewCamera& camera, RenderMode mode,
                           float point_size_px, double min_drawn, const std::string& name) {
  RenderOptions opt;
  opt.mode = mode;
  opt.point_size_px = point_size_px;
  opt.background = {16, 16, 24};
  auto r = renderer.render(id, camera, opt);
  ASSERT_TRUE(r) << r.error().message;
  long drawn = 0;
  for (int y = 0; y < r->color.height; ++y)
    for (int x = 0; x < r->color.width; ++x) drawn += r->color.pixel(x, y)[3] == 255;
  const double fraction = static_cast<double>(drawn) / (r->color.width * r->color.height);
  EXPECT_GT(fraction, min_drawn) << name << ": drawn fraction " << fraction;
  const std::string failure = check_golden(name, r->color);
  EXPECT_TRUE(failure.empty()) << failure;
}

ViewCamera tum_golden_camera(const CaptureCamera& capture, bool at_capture) {
  if (at_capture) return ViewCamera::from_capture(capture, 320, 240);
  auto look = ViewCamera::look_at({-0.4, -0.35, 0.1}, {0.0, 0.1, 1.4}, {0, -1, 0}, 60.0, 320, 240);
  EXPECT_TRUE(look) << look.error().message;
  return look ? *look : ViewCamera::from_capture(capture, 320, 240);
}

}  // namespace rgbdcast::test
