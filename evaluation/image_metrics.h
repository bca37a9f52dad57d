#pragma once
// How close a rendered view is to the captured one: PSNR and SSIM over the pixels that had valid depth and that the
// render covers, and coverage (the fraction of those valid pixels the render covers).
#include <opencv2/core.hpp>

#include "scene/image.h"
#include "scene/result.h"

namespace rgbdcast {

struct ViewFidelity {
  double psnr_db = 0;   // over covered & valid pixels, RGB, peak 255
  double ssim = 0;      // mean SSIM (luma, 11x11 Gaussian window, sigma 1.5) over covered & valid pixels, with
                        // the reference shown outside them so holes do not leak into their windows
  double coverage = 0;  // covered & valid / valid
  // What the operator sees: over every valid pixel, holes shown as the render's background (black).
  double psnr_valid_db = 0;
  double ssim_valid = 0;
  size_t valid_pixels = 0, covered_pixels = 0;
};

// reference_rgb: CV_8UC3 RGB; rendered: RGBA8 of the same size (alpha > 0 = covered); valid: CV_8U mask (non-zero =
// the pixel had depth), same size. Fails on size mismatches or an empty mask.
Result<ViewFidelity> compare_views(const cv::Mat& reference_rgb, const Image& rendered, const cv::Mat& valid);

// An RGBA Image as an RGB cv::Mat (copy), and the alpha > 0 mask.
cv::Mat image_to_rgb_mat(const Image& image);
cv::Mat coverage_mask(const Image& image);

}  // namespace rgbdcast
