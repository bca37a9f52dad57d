// filter_depth (realtime preset): flying pixels, speckles and small gaps of the organized depth image, in O(pixels),
// ahead of the RTIN (reduction/depth_mesh.h). Row bands run on base/worker_threads.h's workers.
#include "reduction/depth_filter.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "base/worker_threads.h"

namespace rgbdcast {

namespace {

// Log depth in steps of kLogStep, 0 = invalid: relative jumps become absolute differences (for filterSpeckles).
constexpr double kLogStep = 0.005;
constexpr double kLogOrigin = 0.02;  // metres mapped to 1

// ln(z) from the float's exponent and a table of ln(1 + m) over the top 12 mantissa bits: within 2.5e-4 (a twentieth
// of a log step), several times cheaper than std::log on a frame's 307,200 pixels.
class FastLog {
 public:
  FastLog() {
    for (int i = 0; i < kSize; ++i) table_[i] = static_cast<float>(std::log1p((i + 0.5) / kSize));
  }
  float operator()(float z) const {
    std::uint32_t bits;
    std::memcpy(&bits, &z, sizeof bits);
    const int exponent = static_cast<int>((bits >> 23) & 0xff) - 127;
    return static_cast<float>(exponent * M_LN2) + table_[(bits >> (23 - kBits)) & (kSize - 1)];
  }

 private:
  static constexpr int kBits = 12, kSize = 1 << kBits;
  float table_[kSize];
};

// Rows y0..y1-1 of `out`.
void log_depth_rows(const cv::Mat& depth_m, cv::Mat& out, int y0, int y1) {
  static_assert(sizeof(float) == 4);
  static const FastLog fast_log;  // a constant table, built once
  const float origin = static_cast<float>(std::log(kLogOrigin)), inv_step = static_cast<float>(1.0 / kLogStep);
  for (int y = y0; y < y1; ++y) {
    const float* z = depth_m.ptr<float>(y);
    std::int16_t* o = out.ptr<std::int16_t>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      if (!(z[x] > 0.f) || !std::isfinite(z[x])) {
        o[x] = 0;
        continue;
      }
      const float l = (fast_log(std::max(z[x], static_cast<float>(kLogOrigin))) - origin) * inv_step + 1.f;
      o[x] = static_cast<std::int16_t>(std::min(l, 32767.f));
    }
  }
}

// One tap of the gap fill's horizontal window over a row: counts, largest and smallest depth (vectorised).
void add_tap(const float* __restrict v, const float* __restrict present, const float* __restrict nearest, int n,
             float* __restrict count, float* __restrict far, float* __restrict near) {
  for (int x = 0; x < n; ++x) {
    count[x] += present[x];
    far[x] = far[x] < v[x] ? v[x] : far[x];
    near[x] = nearest[x] < near[x] ? nearest[x] : near[x];
  }
}
// A row's horizontal counts added to the window's (vectorised).
void add_counts(const float* __restrict row_count, int n, float* __restrict count) {
  for (int x = 0; x < n; ++x) count[x] += row_count[x];
}

// Rows of the image in bands of at least this many, one worker each.
constexpr int kMinBandRows = 32;

}  // namespace

Status DepthFilterParams::validate() const {
  if (!(std::isfinite(jump_relative) && jump_relative > 0 && jump_relative < 10))
    return make_error(ErrorCode::kInvalidArgument, "depth jump must be between 0 and 10 (relative)");
  if (min_region_px < 0 || min_region_px > 1000000)
    return make_error(ErrorCode::kInvalidArgument, "speckle size must be 0..1000000 pixels");
  if (min_support < 0 || min_support > 8)
    return make_error(ErrorCode::kInvalidArgument, "flying-pixel support must be 0..8 neighbours");
  if (gap_fill_px < 0 || gap_fill_px > 64 || smooth_px < 0 || smooth_px > 64)
    return make_error(ErrorCode::kInvalidArgument, "gap fill and smoothing radii must be 0..64 pixels");
  return ok_status();
}

Result<DepthFilterResult> filter_depth(const cv::Mat& depth_m, const DepthFilterParams& p, int threads,
                                       const std::function<void()>& beside_speckles) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1)
    return make_error(ErrorCode::kInvalidArgument, "depth filter: depth must be a non-empty CV_32FC1 image");
  if (auto st = p.validate(); !st) return st.error();
  DepthFilterResult r;
  const int w = depth_m.cols, h = depth_m.rows;
  cv::Mat l(depth_m.size(), CV_16SC1);
  for_row_bands(h, threads, kMinBandRows, [&](int y0, int y1, int) { log_depth_rows(depth_m, l, y0, y1); });
  const int max_diff = std::max(1, static_cast<int>(std::lround(std::log1p(p.jump_relative) / kLogStep)));
  r.valid = static_cast<size_t>(cv::countNonZero(l));

  // Flying pixels: too few 8-neighbours on the same surface. Decided on the input, written to a copy. The input is
  // read through a copy with a one-pixel border of zeros (invalid), so no neighbour needs a bounds check.
  cv::Mat kept = l.clone();
  cv::Mat padded;
  cv::copyMakeBorder(l, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  std::vector<size_t> flying(std::max(1, threads), 0), filled(std::max(1, threads), 0);
  for_row_bands(h, threads, kMinBandRows, [&](int y0, int y1, int band) {
    for (int y = y0; y < y1; ++y) {
      const std::int16_t* up = padded.ptr<std::int16_t>(y) + 1;
      const std::int16_t* row = padded.ptr<std::int16_t>(y + 1) + 1;
      const std::int16_t* down = padded.ptr<std::int16_t>(y + 2) + 1;
      std::int16_t* out = kept.ptr<std::int16_t>(y);
      for (int x = 0; x < w; ++x) {
        const int c = row[x];
        if (c == 0) continue;
        auto same = [&](int n) { return n != 0 && std::abs(n - c) <= max_diff; };
        const int support = same(up[x - 1]) + same(up[x]) + same(up[x + 1]) + same(row[x - 1]) + same(row[x + 1]) +
                            same(down[x - 1]) + same(down[x]) + same(down[x + 1]);
        if (support < p.min_support) {
          out[x] = 0;
          ++flying[band];
        }
      }
    }
  });
  for (size_t n : flying) r.flying += n;
  // Speckles: continuous regions smaller than min_region_px (one serial pass: the caller's work beside it).
  BesideThread beside;  // joined on every way out, an exception from the speckle pass included
  if (beside_speckles) beside.start(beside_speckles);
  const size_t before = static_cast<size_t>(cv::countNonZero(kept));
  if (p.min_region_px > 0) cv::filterSpeckles(kept, 0, p.min_region_px, max_diff);
  r.kept = static_cast<size_t>(cv::countNonZero(kept));
  r.speckles = before - r.kept;
  beside.join();

  r.depth_m.create(h, w, CV_32FC1);
  for_row_bands(h, threads, kMinBandRows, [&](int y0, int y1, int) {
    for (int y = y0; y < y1; ++y) {
      const std::int16_t* k = kept.ptr<std::int16_t>(y);
      const float* in = depth_m.ptr<float>(y);
      float* out = r.depth_m.ptr<float>(y);
      for (int x = 0; x < w; ++x) out[x] = k[x] ? in[x] : 0.f;
    }
  });
  if (p.gap_fill_px > 0) {
    // Gaps: an invalid pixel whose window holds valid depth of one surface (largest / smallest depth within twice
    // the jump) on at least a quarter of its pixels takes the window's mean depth. Gaps between surfaces stay open.
    // The decisions are made on the kept depth, the fills written to the result. The tests are separable: each row's
    // horizontal counts, largest and smallest depth are made once (a ring of 2R + 1 rows per band) and a pixel adds
    // up its window's rows, so no dilation is needed to find the candidates and only the pixels that are filled read
    // their whole window (TUM fr1/xyz frame 1: this pass 1.35 -> 1.0 ms).
    const int R = p.gap_fill_px, win = 2 * R + 1;
    const double max_ratio = 1 + 2 * p.jump_relative;
    const float min_count = 0.25f * win * win;
    constexpr float kNone = std::numeric_limits<float>::infinity();
    for_row_bands(h, threads, kMinBandRows, [&](int y0, int y1, int band) {
      // ring[(yy mod win)]: row yy's horizontal counts, largest and smallest depth over x - R .. x + R, of the kept
      // depth only.
      struct Row {
        std::vector<float> depth, count, far, near;  // depth: the kept depth after R zeros, and R + kLanes after it
      };
      constexpr int kLanes = 8;  // the means are summed for this many neighbouring pixels at a time (vectorised)
      std::vector<Row> ring(win);
      for (Row& row : ring) {
        row.depth.assign(w + 2 * R + kLanes, 0.f);
        for (auto* v : {&row.count, &row.far, &row.near}) v->assign(w, 0.f);
      }
      // The row padded by R on each side: 1 where there is depth, and its depth or +inf.
      std::vector<float> present(w + 2 * R, 0.f), nearest(w + 2 * R, kNone);
      std::vector<float> count(w);  // the kept pixels in each pixel's window
      std::vector<int> fills;       // this row's pixels to fill
      auto aggregate = [&](int yy, Row& row) {
        const std::int16_t* k = kept.ptr<std::int16_t>(yy);
        const float* z = depth_m.ptr<float>(yy);
        float* padded = row.depth.data();
        for (int x = 0; x < w; ++x) {
          const bool has = k[x] != 0;
          padded[x + R] = has ? z[x] : 0.f, present[x + R] = has ? 1.f : 0.f, nearest[x + R] = has ? z[x] : kNone;
        }
        float* __restrict c = row.count.data();
        float* __restrict far = row.far.data();
        float* __restrict near = row.near.data();
        std::copy_n(present.data(), w, c);
        std::copy_n(padded, w, far);
        std::copy_n(nearest.data(), w, near);
        for (int d = 1; d < win; ++d)  // tap by tap over the whole row
          add_tap(padded + d, present.data() + d, nearest.data() + d, w, c, far, near);
      };
      const int first = std::max(0, y0 - R);
      for (int yy = first; yy < std::min(h, y0 + R); ++yy) aggregate(yy, ring[yy % win]);
      for (int y = y0; y < y1; ++y) {
        if (y + R < h) aggregate(y + R, ring[(y + R) % win]);
        const int lo = std::max(0, y - R), hi = std::min(h - 1, y + R);
        std::fill(count.begin(), count.end(), 0.f);
        for (int yy = lo; yy <= hi; ++yy) add_counts(ring[yy % win].count.data(), w, count.data());
        const std::int16_t* k = kept.ptr<std::int16_t>(y);
        fills.clear();
        for (int x = 0; x < w; ++x) {
          if (k[x] || count[x] < min_count) continue;
          float far = 0, near = kNone;
          for (int yy = lo; yy <= hi; ++yy) {
            const Row& row = ring[yy % win];
            far = std::max(far, row.far[x]), near = std::min(near, row.near[x]);
          }
          if (far <= near * max_ratio) fills.push_back(x);
        }
        // The means, summed in the window's row-major order (as the fill always has: the same float rounding; the
        // zeros of the pixels without depth add nothing), kLanes neighbouring pixels at a time.
        float* out = r.depth_m.ptr<float>(y);
        for (size_t i = 0; i < fills.size();) {
          const int x0 = fills[i];
          float sum[kLanes] = {};
          for (int yy = lo; yy <= hi; ++yy) {
            const float* row = ring[yy % win].depth.data() + x0;  // pixel x0 + l's window starts at row[l]
            for (int d = 0; d < win; ++d)
              for (int l = 0; l < kLanes; ++l) sum[l] += row[l + d];
          }
          for (; i < fills.size() && fills[i] < x0 + kLanes; ++i) out[fills[i]] = sum[fills[i] - x0] / count[fills[i]];
        }
        filled[band] += fills.size();
      }
    });
    for (size_t n : filled) r.filled += n;
  }
  // Vertex depth: the mean inverse depth over a full window of one surface (exact on a plane, whose inverse depth is
  // affine in the pixel), else the pixel's own. The fit is still judged on the pixels themselves.
  r.vertex_depth_m = p.smooth_px > 0 ? r.depth_m.clone() : r.depth_m;  // (read-only from here on)
  if (p.smooth_px > 0) {
    const cv::Size win(2 * p.smooth_px + 1, 2 * p.smooth_px + 1);
    const cv::Mat valid = r.depth_m > 0;
    cv::Mat inv, inv_sum, count, valid_f, far, near_inv;
    cv::divide(1.0, r.depth_m, inv);
    inv.setTo(0, ~valid);
    valid.convertTo(valid_f, CV_32F, 1.0 / 255);
    cv::boxFilter(inv, inv_sum, CV_32F, win, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
    cv::boxFilter(valid_f, count, CV_32F, win, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
    cv::dilate(r.depth_m, far, cv::getStructuringElement(cv::MORPH_RECT, win));
    cv::dilate(inv, near_inv, cv::getStructuringElement(cv::MORPH_RECT, win));
    const double max_ratio = 1 + 2 * p.jump_relative;
    const float full = static_cast<float>(win.area()) - 0.5f;
    for (int y = 0; y < h; ++y) {
      float* out = r.vertex_depth_m.ptr<float>(y);
      const float *s_ = inv_sum.ptr<float>(y), *c = count.ptr<float>(y), *f = far.ptr<float>(y),
                  *n = near_inv.ptr<float>(y);
      for (int x = 0; x < w; ++x)
        if (out[x] > 0 && c[x] > full && f[x] * n[x] <= max_ratio) out[x] = c[x] / s_[x];
    }
  }
  return r;
}

}  // namespace rgbdcast
