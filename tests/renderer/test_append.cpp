// Renderer::append (a live mission grows by a keyframe): a scene uploaded in parts and grown by appends
// renders exactly what the whole scene uploaded at once renders, on both backends (Vulkan under validation); a failed
// append leaves the resident scene as it was; an unknown id is kNotFound. A view drawn in batches over one another
// (RenderOptions::keep_targets, the parts of one batch released before the next) renders what one pass renders.
#include "tests/renderer/renderer_fixture.h"
#include "tests/renderer/synthetic_scene.h"

namespace rgbdcast::test {
namespace {

class Append : public BackendTest {};

Scene part(const Scene& whole, size_t node) {
  Scene s;
  s.nodes.push_back(whole.nodes.at(node));
  return s;
}

TEST_P(Append, AppendedNodesRenderLikeOneUpload) {
  const Scene whole = synthetic_scene();
  ASSERT_GE(whole.nodes.size(), 3u);
  auto all = renderer_->upload(whole);
  ASSERT_TRUE(all) << all.error().message;
  auto grown = renderer_->upload(part(whole, 0));
  ASSERT_TRUE(grown) << grown.error().message;
  RenderOptions options;
  options.background = {16, 16, 24};
  const ViewCamera cam = look_at_camera();
  auto first = renderer_->render(*grown, cam, options);
  ASSERT_TRUE(first);
  for (size_t i = 1; i < whole.nodes.size(); ++i) {
    double ms = -1;
    auto st = renderer_->append(*grown, part(whole, i), &ms);
    ASSERT_TRUE(st) << st.error().message;
    EXPECT_GE(ms, 0.0);
  }
  for (RenderMode mode : {RenderMode::kMesh, RenderMode::kPoints}) {
    options.mode = mode;
    auto a = renderer_->render(*all, cam, options);
    auto b = renderer_->render(*grown, cam, options);
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->color.data, b->color.data) << to_string(mode);
  }
  options.mode = RenderMode::kMesh;
  auto last = renderer_->render(*grown, cam, options);
  ASSERT_TRUE(last);
  EXPECT_NE(first->color.data, last->color.data) << "the appended nodes drew nothing";
}

TEST_P(Append, FailedAppendLeavesTheSceneAndUnknownIdIsNotFound) {
  const Scene whole = synthetic_scene();
  auto id = renderer_->upload(part(whole, 0));
  ASSERT_TRUE(id);
  RenderOptions options;
  const ViewCamera cam = look_at_camera();
  auto before = renderer_->render(*id, cam, options);
  ASSERT_TRUE(before);
  Scene broken = part(whole, 1);
  broken.nodes[0].mesh.indices.push_back(1u << 30);  // an index out of range
  if (broken.nodes[0].mesh.indices.size() % 3 != 0) {
    broken.nodes[0].mesh.indices.push_back(0);
    broken.nodes[0].mesh.indices.push_back(0);
  }
  EXPECT_FALSE(renderer_->append(*id, broken));
  EXPECT_FALSE(renderer_->append(*id, Scene{}));  // nothing to draw
  auto after = renderer_->render(*id, cam, options);
  ASSERT_TRUE(after);
  EXPECT_EQ(before->color.data, after->color.data);
  auto unknown = renderer_->append(987654, part(whole, 1));
  ASSERT_FALSE(unknown);
  EXPECT_EQ(unknown.error().code, ErrorCode::kNotFound);
}

TEST_P(Append, BatchesDrawnOverOneAnotherRenderLikeOnePass) {
  const Scene whole = synthetic_scene();
  ASSERT_GE(whole.nodes.size(), 3u);
  const ViewCamera cam = look_at_camera();
  RenderOptions options;
  options.background = {16, 16, 24};
  options.want_depth = true;
  for (RenderMode mode : {RenderMode::kMesh, RenderMode::kPoints}) {
    options.mode = mode;
    std::vector<ResidentSceneId> ids;
    for (size_t i = 0; i < whole.nodes.size(); ++i) {
      auto id = renderer_->upload(part(whole, i));
      ASSERT_TRUE(id) << id.error().message;
      ids.push_back(*id);
    }
    auto one_pass = renderer_->render_scenes(ids, cam, options);
    ASSERT_TRUE(one_pass) << one_pass.error().message;
    // One node a batch, each released once drawn, the image read back after the last only.
    Result<RenderResult> batched = make_error(ErrorCode::kInternal, "not drawn");
    for (size_t i = 0; i < ids.size(); ++i) {
      RenderOptions batch = options;
      batch.keep_targets = i > 0;
      batch.read_back = i + 1 == ids.size();
      batched = renderer_->render_scenes(std::span<const ResidentSceneId>(&ids[i], 1), cam, batch);
      ASSERT_TRUE(batched) << batched.error().message;
      if (!batch.read_back) {
        EXPECT_TRUE(batched->color.data.empty());
      }
      renderer_->release(ids[i]);
    }
    EXPECT_EQ(batched->color.data, one_pass->color.data) << to_string(mode);
    EXPECT_EQ(batched->depth_m, one_pass->depth_m) << to_string(mode);
    EXPECT_NE(one_pass->color.data, renderer_->render_scenes({}, cam, options)->color.data) << "nothing drawn";
  }
  // Drawing over a view of another size is refused, and leaves the next fresh view intact.
  ViewCamera other = cam;
  other.width = cam.width / 2;
  other.height = cam.height / 2;
  RenderOptions keep = options;
  keep.keep_targets = true;
  auto refused = renderer_->render_scenes({}, other, keep);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidArgument);
  EXPECT_TRUE(renderer_->render_scenes({}, other, options));
}

INSTANTIATE_TEST_SUITE_P(Backends, Append, kBackends);

}  // namespace
}  // namespace rgbdcast::test
