#pragma once
// Fidelity of what the receiver has: render its Scene at a set of views (the capture pose, then novel poses) and
// compare each render with the real colour image of that view over that view's valid-depth pixels (compare_views).
// Meshes are drawn as meshes; clouds as square splats of a given size.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "evaluation/image_metrics.h"
#include "renderer/renderer.h"
#include "scene/camera.h"
#include "scene/scene.h"

namespace rgbdcast::bench {

// One view to judge at: where the camera is (in the sent frame's camera frame) and what it really saw.
struct ReferenceView {
  std::string name;  // "capture", "frame 1", ...
  ViewCamera camera;
  cv::Mat color_rgb;  // CV_8UC3
  cv::Mat valid;      // CV_8U, non-zero where that frame had depth
};

struct ViewSetFidelity {
  ViewFidelity capture;                                          // views[0]
  std::vector<ViewFidelity> novel;                               // views[1..]
  double novel_psnr_db = 0, novel_ssim = 0, novel_coverage = 0;  // means over novel views (0 when none)
  double novel_psnr_valid_db = 0, novel_ssim_valid = 0;          // the same over every valid pixel, holes black
};

// Renders `id` at every view (views[0] is the capture pose) and compares. The renders are kept in `renders` (one per
// view) when it is given, for comparisons over pixels every representation covers (common_pixels).
Result<ViewSetFidelity> measure_views(Renderer& renderer, ResidentSceneId id, const RenderOptions& options,
                                      const std::vector<ReferenceView>& views, std::vector<Image>* renders = nullptr);

// The pixels of a view that had valid depth and that every one of `renders` covers.
cv::Mat common_pixels(const ReferenceView& view, const std::vector<const Image*>& renders);

}  // namespace rgbdcast::bench
