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

inline const auto kBackends = ::testing::Values(std::string("vulkan"), std::string("osmesa"));

}  // namespace rgbdcast::test
