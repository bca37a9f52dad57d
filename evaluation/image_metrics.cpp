#include "evaluation/image_metrics.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

namespace rgbdcast {

cv::Mat image_to_rgb_mat(const Image& image) {
  cv::Mat src(image.height, image.width, CV_8UC(image.channels), const_cast<std::uint8_t*>(image.data.data()));
  cv::Mat rgb;
  if (image.channels == 4)
    cv::cvtColor(src, rgb, cv::COLOR_RGBA2RGB);
  else
    rgb = src.clone();
  return rgb;
}

cv::Mat coverage_mask(const Image& image) {
  cv::Mat mask(image.height, image.width, CV_8U, cv::Scalar(255));
  if (image.channels != 4) return mask;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) mask.at<std::uint8_t>(y, x) = image.pixel(x, y)[3] > 0 ? 255 : 0;
  return mask;
}

// SSIM map of two single-channel float images (Wang et al. 2004, K1 = 0.01, K2 = 0.03, L = 255).
static cv::Mat ssim_map(const cv::Mat& a, const cv::Mat& b) {
  const double c1 = 6.5025, c2 = 58.5225;
  cv::Mat mu_a, mu_b, a2, b2, ab;
  cv::GaussianBlur(a, mu_a, cv::Size(11, 11), 1.5);
  cv::GaussianBlur(b, mu_b, cv::Size(11, 11), 1.5);
  cv::GaussianBlur(a.mul(a), a2, cv::Size(11, 11), 1.5);
  cv::GaussianBlur(b.mul(b), b2, cv::Size(11, 11), 1.5);
  cv::GaussianBlur(a.mul(b), ab, cv::Size(11, 11), 1.5);
  const cv::Mat mu_a2 = mu_a.mul(mu_a), mu_b2 = mu_b.mul(mu_b), mu_ab = mu_a.mul(mu_b);
  const cv::Mat var_a = a2 - mu_a2, var_b = b2 - mu_b2, cov = ab - mu_ab;
  cv::Mat num = (2 * mu_ab + c1).mul(2 * cov + c2);
  cv::Mat den = (mu_a2 + mu_b2 + c1).mul(var_a + var_b + c2);
  cv::Mat out;
  cv::divide(num, den, out);
  return out;
}

Result<ViewFidelity> compare_views(const cv::Mat& reference_rgb, const Image& rendered, const cv::Mat& valid) {
  if (reference_rgb.type() != CV_8UC3 || valid.type() != CV_8U)
    return make_error(ErrorCode::kInvalidArgument, "compare_views: reference must be RGB8 and the mask 8-bit");
  if (rendered.width != reference_rgb.cols || rendered.height != reference_rgb.rows ||
      valid.size() != reference_rgb.size())
    return make_error(ErrorCode::kInvalidArgument,
                      "compare_views: the render, the reference and the mask differ in size");
  cv::Mat render_rgb = image_to_rgb_mat(rendered);
  const cv::Mat drawn = coverage_mask(rendered);
  render_rgb.setTo(cv::Scalar::all(0), ~drawn);  // holes are background (black), whatever their colour channels hold
  cv::Mat covered = drawn & (valid > 0);
  ViewFidelity f;
  f.valid_pixels = static_cast<size_t>(cv::countNonZero(valid));
  f.covered_pixels = static_cast<size_t>(cv::countNonZero(covered));
  if (f.valid_pixels == 0) return make_error(ErrorCode::kEmpty, "compare_views: no valid pixels to compare");
  f.coverage = double(f.covered_pixels) / double(f.valid_pixels);
  cv::Mat diff;
  cv::absdiff(reference_rgb, render_rgb, diff);
  diff.convertTo(diff, CV_64FC3);
  diff = diff.mul(diff);
  auto psnr = [](const cv::Scalar& sum, size_t n) {
    const double mse = (sum[0] + sum[1] + sum[2]) / (3.0 * n);
    return mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : 99.0;
  };
  const cv::Mat valid_mask = valid > 0;
  f.psnr_valid_db = psnr(cv::sum(diff.clone().setTo(cv::Scalar::all(0), ~valid_mask)), f.valid_pixels);
  // Pixels without depth are not judged: show the reference there so they do not leak into the windows.
  cv::Mat seen = reference_rgb.clone();
  render_rgb.copyTo(seen, valid_mask);
  cv::Mat ga, gr;
  cv::cvtColor(reference_rgb, ga, cv::COLOR_RGB2GRAY);
  cv::cvtColor(seen, gr, cv::COLOR_RGB2GRAY);
  ga.convertTo(ga, CV_64F);
  gr.convertTo(gr, CV_64F);
  f.ssim_valid = cv::mean(ssim_map(ga, gr), valid_mask)[0];
  if (f.covered_pixels == 0) return f;
  f.psnr_db = psnr(cv::sum(diff.setTo(cv::Scalar::all(0), ~covered)), f.covered_pixels);

  // SSIM windows are 11x11: outside the covered pixels the render is background, which would leak into the windows
  // of covered pixels near every hole. Composite the render over the reference so only covered pixels can differ.
  cv::Mat composite = reference_rgb.clone();
  render_rgb.copyTo(composite, covered);
  cv::Mat gb;
  cv::cvtColor(composite, gb, cv::COLOR_RGB2GRAY);
  gb.convertTo(gb, CV_64F);
  f.ssim = cv::mean(ssim_map(ga, gb), covered)[0];
  return f;
}

}  // namespace rgbdcast
