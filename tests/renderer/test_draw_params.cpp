// The draw parameters both backends upload: laid out as shaders/scene.vert's DrawParams block.
#include <gtest/gtest.h>

#include <cstddef>

#include "renderer/render_scene.h"

namespace rgbdcast {
namespace {

TEST(DrawParams, LayoutOfTheShadersBlock) {
  EXPECT_EQ(offsetof(DrawParams, clip_from_node), 0u);
  EXPECT_EQ(offsetof(DrawParams, params), 64u);
  EXPECT_EQ(sizeof(DrawParams), 80u);
}

TEST(DrawParams, MatrixColumnMajorPointSizeAndColourSource) {
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = 10 * r + c + 0.5;
  struct Case {
    float point_size_px;
    ColorSource source;
    float source_value;
  };
  for (const Case& c : {Case{1.0f, ColorSource::kVertex, 0.0f}, Case{3.5f, ColorSource::kTextureFragment, 1.0f},
                        Case{255.0f, ColorSource::kTextureVertex, 2.0f}}) {
    const DrawParams p = make_draw_params(m, c.point_size_px, c.source);
    for (int r = 0; r < 4; ++r)
      for (int col = 0; col < 4; ++col) EXPECT_EQ(p.clip_from_node[4 * col + r], static_cast<float>(m(r, col)));
    EXPECT_EQ(p.params[0], c.point_size_px);
    EXPECT_EQ(p.params[1], c.source_value);
    EXPECT_EQ(p.params[2], 0.0f);
    EXPECT_EQ(p.params[3], 0.0f);
  }
}

}  // namespace
}  // namespace rgbdcast
