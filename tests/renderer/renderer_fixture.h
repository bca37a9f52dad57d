#pragma once
// A test fixture per backend: Vulkan always runs with VK_LAYER_KHRONOS_validation, and every Vulkan test fails when
// the layer reported an error (counted by the renderer's debug-utils messenger).
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "renderer/renderer.h"

namespace rgbdcast::test {

// "vulkan" (with validation) or "osmesa". Null with the error in *error when the backend cannot be created.
std::unique_ptr<Renderer> make_test_renderer(const std::string& backend, std::string* error);

class BackendTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override;
  void TearDown() override;
  std::unique_ptr<Renderer> renderer_;
};

// Renders a resident scene with the golden settings (background 16,16,24), expects at least min_drawn of the pixels
// drawn (so a blank image can never become a golden) and compares with the golden `name`.
void expect_matches_golden(Renderer& renderer, ResidentSceneId id, const ViewCamera& camera, RenderMode mode,
                           float point_size_px, double min_drawn, const std::string& name);

// The cameras of the TUM fr1/xyz frame 0 goldens (test_golden_tum.cpp, test_golden_realtime.cpp), 320x240: the
// capture camera, or a look-at from above and to the left of it onto the desk.
ViewCamera tum_golden_camera(const CaptureCamera& capture, bool at_capture);

inline const auto kBackends = ::testing::Values(std::string("vulkan"), std::string("osmesa"));

}  // namespace rgbdcast::test
