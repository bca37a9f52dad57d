#include "bench/transmission/fidelity.h"

namespace rgbdcast::bench {

Result<ViewSetFidelity> measure_views(Renderer& renderer, ResidentSceneId id, const RenderOptions& options,
                                      const std::vector<ReferenceView>& views, std::vector<Image>* renders) {
  ViewSetFidelity out;
  if (renders) renders->clear();
  for (size_t i = 0; i < views.size(); ++i) {
    auto rendered = renderer.render(id, views[i].camera, options);
    if (!rendered) return rendered.error();
    auto fidelity = compare_views(views[i].color_rgb, rendered->color, views[i].valid);
    if (!fidelity) return make_error(fidelity.error().code, views[i].name + ": " + fidelity.error().message);
    if (renders) renders->push_back(std::move(rendered->color));
    if (i == 0) {
      out.capture = *fidelity;
      continue;
    }
    out.novel.push_back(*fidelity);
    out.novel_psnr_db += fidelity->psnr_db;
    out.novel_ssim += fidelity->ssim;
    out.novel_coverage += fidelity->coverage;
    out.novel_psnr_valid_db += fidelity->psnr_valid_db;
    out.novel_ssim_valid += fidelity->ssim_valid;
  }
  if (!out.novel.empty()) {
    const double n = static_cast<double>(out.novel.size());
    out.novel_psnr_db /= n;
    out.novel_ssim /= n;
    out.novel_coverage /= n;
    out.novel_psnr_valid_db /= n;
    out.novel_ssim_valid /= n;
  }
  return out;
}

cv::Mat common_pixels(const ReferenceView& view, const std::vector<const Image*>& renders) {
  cv::Mat mask = view.valid != 0;
  for (const Image* r : renders) mask &= coverage_mask(*r);
  return mask;
}

}  // namespace rgbdcast::bench
