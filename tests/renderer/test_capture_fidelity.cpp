// On a real capture (TUM fr1/xyz frame 0): the full cloud rendered as 1-pixel splats at the capture camera gives the
// captured colour image back pixel for pixel on every valid-depth pixel, and the captured depth, in both backends.
// This is the projection contract of renderer/render_camera.h checked on 230k real points.
#include <cmath>

#include "input/frame_source.h"
#include "reduction/pipeline.h"
#include "tests/common/test_data.h"
#include "tests/renderer/renderer_fixture.h"

namespace rgbdcast::test {
namespace {

class CaptureFidelity : public BackendTest {};

TEST_P(CaptureFidelity, FullCloudReproducesTheCapturedFrame) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz/rgb.txt");
  auto source = open_frame_source(data_path("tum/rgbd_dataset_freiburg1_xyz"), SourceOptions{});
  ASSERT_TRUE(source) << source.error().message;
  auto frame = (*source)->frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  Scene scene;
  scene.nodes.emplace_back();
  scene.nodes[0].points = full_cloud(*frame);
  CaptureCamera cap;
  cap.intrinsics = frame->intrinsics;
  const ViewCamera cam = ViewCamera::from_capture(cap);
  ASSERT_EQ(cam.width, frame->color_rgb.cols);
  ASSERT_EQ(cam.height, frame->color_rgb.rows);
  auto id = renderer_->upload(scene);
  ASSERT_TRUE(id) << id.error().message;
  RenderOptions opt;
  opt.mode = RenderMode::kPoints;
  opt.point_size_px = 1.0f;
  opt.want_depth = true;
  auto r = renderer_->render(id.value(), cam, opt);
  ASSERT_TRUE(r) << r.error().message;

  long valid = 0, same_color = 0, same_depth = 0, background_ok = 0, invalid = 0;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const float d = frame->depth_m.at<float>(v, u);
      const std::uint8_t* px = r->color.pixel(u, v);
      const float rd = r->depth_m[static_cast<size_t>(v) * cam.width + u];
      if (!(d > 0.0f)) {
        ++invalid;
        background_ok += px[3] == 0 && rd == 0.0f;
        continue;
      }
      ++valid;
      const cv::Vec3b c = frame->color_rgb.at<cv::Vec3b>(v, u);
      same_color += px[0] == c[0] && px[1] == c[1] && px[2] == c[2] && px[3] == 255;
      same_depth += std::abs(rd - d) <= 1e-4f * d;
    }
  ASSERT_GT(valid, 200000) << "fr1/xyz frame 0 has about 219k valid pixels after undistortion";
  EXPECT_EQ(same_color, valid) << "pixels whose colour is not the captured one: " << valid - same_color;
  EXPECT_EQ(same_depth, valid) << "pixels whose depth is not the captured one: " << valid - same_depth;
  EXPECT_EQ(background_ok, invalid) << "pixels without depth must stay background";
  std::printf("%s: %ld valid pixels, %ld exact colour, %ld exact depth; %ld background pixels empty\n",
              GetParam().c_str(), valid, same_color, same_depth, background_ok);
}

INSTANTIATE_TEST_SUITE_P(Backends, CaptureFidelity, kBackends);

}  // namespace
}  // namespace rgbdcast::test
