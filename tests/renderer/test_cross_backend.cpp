// Vulkan and OSMesa render the same scene alike: within the golden tolerance of each other.
#include <cstdio>

#include "tests/common/test_data.h"
#include "tests/renderer/image_compare.h"
#include "tests/renderer/renderer_fixture.h"
#include "tests/renderer/synthetic_scene.h"

namespace rgbdcast::test {
namespace {

TEST(CrossBackend, VulkanAndOsmesaAgree) {
  std::string error;
  auto vk = make_test_renderer("vulkan", &error);
  ASSERT_TRUE(vk) << error;
  auto gl = make_test_renderer("osmesa", &error);
  ASSERT_TRUE(gl) << error;
  const Scene scene = synthetic_scene();
  auto vk_id = vk->upload(scene);
  auto gl_id = gl->upload(scene);
  ASSERT_TRUE(vk_id && gl_id);
  for (RenderMode mode : {RenderMode::kMesh, RenderMode::kPoints})
    for (const auto& [name, cam] :
         {std::pair{"intrinsics", intrinsics_camera()}, std::pair{"lookat", look_at_camera()}}) {
      RenderOptions opt;
      opt.mode = mode;
      opt.point_size_px = 3.0f;
      opt.want_depth = true;
      auto a = vk->render(vk_id.value(), cam, opt);
      auto b = gl->render(gl_id.value(), cam, opt);
      ASSERT_TRUE(a && b);
      const CompareResult c = compare_images(a->color, b->color);
      const std::string tag = std::string(to_string(mode)) + "_" + name;
      const CompareResult exact = compare_images(a->color, b->color, 0, 0);
      std::printf("%s: %ld pixels differ at all (%.3f %%), %ld beyond the golden tolerance\n", tag.c_str(),
                  exact.bad_pixels, 100.0 * exact.bad_fraction, c.bad_pixels);
      if (!c.pass()) {
        const std::string out = binary_path("tests/renderer/golden/cross_" + tag);
        write_png(out + ".vulkan.png", a->color);
        write_png(out + ".osmesa.png", b->color);
        write_png(out + ".diff.png", c.diff);
        ADD_FAILURE() << tag << ": " << c.bad_pixels << " pixels differ; see " << out << ".*.png";
      }
      // Depth agrees too where both drew (sub-millimetre at these distances).
      double worst = 0.0;
      for (size_t i = 0; i < a->depth_m.size(); ++i)
        if (a->depth_m[i] > 0 && b->depth_m[i] > 0)
          worst = std::max(worst, double(std::abs(a->depth_m[i] - b->depth_m[i])));
      EXPECT_LT(worst, 0.05) << tag << " (edges may differ by a pixel, so allow a step)";
    }
  EXPECT_EQ(vk->validation_errors(), 0);
}

}  // namespace
}  // namespace rgbdcast::test
