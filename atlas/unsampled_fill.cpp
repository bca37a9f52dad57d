#include "atlas/unsampled_fill.h"

#include <algorithm>
#include <cmath>

namespace rgbdcast {

namespace {

// Marks the texels a bilinear lookup inside the triangle (a, b, c) (texel units) reads, by the separating-axis test
// of the triangle against each texel's open square of half-width 1 (shrunk by kTouch, so that a triangle that only
// touches it, giving the texel a bilinear weight of zero, does not count; unbounded towards the outside at the
// texture's border, where CLAMP_TO_EDGE reads the border texel). Interior rows are marked as one span each (every
// condition of the test is linear in x); border texels are tested one by one.
class TriangleMarker {
 public:
  TriangleMarker(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, int width, int height)
      : w_(width), h_(height) {
    minx_ = std::min({a.x(), b.x(), c.x()}), maxx_ = std::max({a.x(), b.x(), c.x()});
    miny_ = std::min({a.y(), b.y(), c.y()}), maxy_ = std::max({a.y(), b.y(), c.y()});
    const double area2 = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    flat_ = !(std::abs(area2) > 1e-12);  // no edge test for a degenerate triangle: its bounding box only
    const double s = area2 > 0 ? 1.0 : -1.0;
    const Eigen::Vector2d* v[3] = {&a, &b, &c};
    for (int e = 0; e < 3; ++e) {
      const Eigen::Vector2d edge = *v[(e + 1) % 3] - *v[e];
      n_[e] = s * Eigen::Vector2d(edge.y(), -edge.x());  // outward: the triangle is n.p <= d
      d_[e] = n_[e].dot(*v[e]);
    }
  }

  void mark(std::uint8_t* mask) const {
    auto clampi = [](double v, int hi) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(hi))); };
    const int x0 = clampi(std::floor(minx_ - 1.5), w_ - 1), x1 = clampi(std::ceil(maxx_ + 0.5), w_ - 1);
    const int y0 = clampi(std::floor(miny_ - 1.5), h_ - 1), y1 = clampi(std::ceil(maxy_ + 0.5), h_ - 1);
    for (int y = y0; y <= y1; ++y) {
      std::uint8_t* row = mask + static_cast<size_t>(y) * w_;
      if (y == 0 || y == h_ - 1 || w_ < 3) {
        for (int x = x0; x <= x1; ++x)
          if (touches(x, y)) row[x] = 1;
        continue;
      }
      if (x0 == 0 && touches(0, y)) row[0] = 1;
      if (x1 == w_ - 1 && touches(w_ - 1, y)) row[w_ - 1] = 1;
      int lo, hi;
      if (span(y, &lo, &hi)) std::fill(row + lo, row + hi + 1, std::uint8_t{1});
    }
  }

 private:
  static constexpr double kFar = 1e30, kTouch = 1e-3;

  bool separated(double bx0, double bx1, double by0, double by1) const {
    if (maxx_ < bx0 || minx_ > bx1 || maxy_ < by0 || miny_ > by1) return true;
    for (int e = 0; e < 3 && !flat_; ++e) {
      const double lo =
          (n_[e].x() > 0 ? n_[e].x() * bx0 : n_[e].x() * bx1) + (n_[e].y() > 0 ? n_[e].y() * by0 : n_[e].y() * by1);
      if (lo > d_[e]) return true;
    }
    return false;
  }
  bool touches(int x, int y) const {
    return !separated(x == 0 ? -kFar : x - 0.5 + kTouch, x == w_ - 1 ? kFar : x + 1.5 - kTouch,
                      y == 0 ? -kFar : y - 0.5 + kTouch, y == h_ - 1 ? kFar : y + 1.5 - kTouch);
  }
  // The interior texels 1..w-2 of interior row y that the test keeps, as [*lo, *hi].
  bool span(int y, int* lo, int* hi) const {
    const double by0 = y - 0.5 + kTouch, by1 = y + 1.5 - kTouch;
    if (maxy_ < by0 || miny_ > by1) return false;
    // Box [x - 0.5 + k, x + 1.5 - k]: overlaps the bounding box in x, and no edge separates it.
    double xl = std::max(1.0, minx_ - 1.5 + kTouch), xr = std::min(w_ - 2.0, maxx_ + 0.5 - kTouch);
    for (int e = 0; e < 3 && !flat_; ++e) {
      const double nx = n_[e].x(), ny = n_[e].y();
      // n.(box corner nearest the triangle) <= d, with that corner's x = x + cx: nx x <= r.
      const double cx = nx > 0 ? -0.5 + kTouch : 1.5 - kTouch;
      const double r = d_[e] - nx * cx - (ny > 0 ? ny * by0 : ny * by1);
      if (nx > 0) {
        xr = std::min(xr, r / nx);
      } else if (nx < 0) {
        xl = std::max(xl, r / nx);
      } else if (r < 0) {
        return false;
      }
    }
    *lo = static_cast<int>(std::ceil(xl));
    *hi = static_cast<int>(std::floor(xr));
    return *lo <= *hi;
  }

  int w_, h_;
  double minx_, maxx_, miny_, maxy_;
  bool flat_;
  Eigen::Vector2d n_[3];
  double d_[3];
};

// One level of the pyramid: C floats per texel and whether the texel holds an average of sampled texels.
struct Level {
  int w = 0, h = 0;
  std::vector<float> value;
  std::vector<std::uint8_t> valid;
};

// Bilinear lookup of the (complete) coarse level at the centre of fine texel (x, y).
template <int C>
void upsample(const Level& coarse, int x, int y, float out[C]) {
  const float X = 0.5f * (x + 0.5f) - 0.5f, Y = 0.5f * (y + 0.5f) - 0.5f;
  const int xa = std::max(0, static_cast<int>(std::floor(X))), ya = std::max(0, static_cast<int>(std::floor(Y)));
  const int xb = std::min(coarse.w - 1, xa + 1), yb = std::min(coarse.h - 1, ya + 1);
  const float fx = std::clamp(X - xa, 0.0f, 1.0f), fy = std::clamp(Y - ya, 0.0f, 1.0f);
  const float* p00 = &coarse.value[(static_cast<size_t>(ya) * coarse.w + xa) * C];
  const float* p01 = &coarse.value[(static_cast<size_t>(ya) * coarse.w + xb) * C];
  const float* p10 = &coarse.value[(static_cast<size_t>(yb) * coarse.w + xa) * C];
  const float* p11 = &coarse.value[(static_cast<size_t>(yb) * coarse.w + xb) * C];
  for (int c = 0; c < C; ++c) {
    const float top = p00[c] + fx * (p01[c] - p00[c]), bot = p10[c] + fx * (p11[c] - p10[c]);
    out[c] = top + fy * (bot - top);
  }
}

// Averages the valid texels of each 2x2 block of `fine` (values as floats via get(x, y, c), validity via ok(x, y)).
template <int C, typename Get, typename Ok>
Level downsample(int fw, int fh, Get get, Ok ok) {
  Level l;
  l.w = (fw + 1) / 2;
  l.h = (fh + 1) / 2;
  l.value.assign(static_cast<size_t>(l.w) * l.h * C, 0.0f);
  l.valid.assign(static_cast<size_t>(l.w) * l.h, 0);
  for (int y = 0; y < l.h; ++y)
    for (int x = 0; x < l.w; ++x) {
      float sum[C] = {};
      int n = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int fx = 2 * x + dx, fy = 2 * y + dy;
          if (fx >= fw || fy >= fh || !ok(fx, fy)) continue;
          ++n;
          for (int c = 0; c < C; ++c) sum[c] += get(fx, fy, c);
        }
      if (n == 0) continue;
      const size_t i = static_cast<size_t>(y) * l.w + x;
      l.valid[i] = 1;
      for (int c = 0; c < C; ++c) l.value[i * C + c] = sum[c] / n;
    }
  return l;
}

// downsample() for level 0, straight from the image's bytes (the bulk of the work: every texel is read once).
template <int C>
Level downsample_image(const Image& image, const std::vector<std::uint8_t>& sampled) {
  Level l;
  const int fw = image.width, fh = image.height;
  l.w = (fw + 1) / 2;
  l.h = (fh + 1) / 2;
  l.value.assign(static_cast<size_t>(l.w) * l.h * C, 0.0f);
  l.valid.assign(static_cast<size_t>(l.w) * l.h, 0);
  const std::uint8_t* data = image.data.data();
  const std::uint8_t* mask = sampled.data();
  for (int y = 0; y < l.h; ++y) {
    const int rows = std::min(2, fh - 2 * y);
    float* out = &l.value[static_cast<size_t>(y) * l.w * C];
    std::uint8_t* valid = &l.valid[static_cast<size_t>(y) * l.w];
    for (int x = 0; x < l.w; ++x, out += C) {
      const int cols = std::min(2, fw - 2 * x);
      int sum[C] = {}, n = 0;
      for (int dy = 0; dy < rows; ++dy) {
        const size_t i = static_cast<size_t>(2 * y + dy) * fw + 2 * x;
        for (int dx = 0; dx < cols; ++dx) {
          if (!mask[i + dx]) continue;
          ++n;
          const std::uint8_t* p = data + (i + dx) * C;
          for (int c = 0; c < C; ++c) sum[c] += p[c];
        }
      }
      if (n == 0) continue;
      valid[x] = 1;
      const float inv = 1.0f / n;
      for (int c = 0; c < C; ++c) out[c] = sum[c] * inv;
    }
  }
  return l;
}

template <int C>
void push_pull(Image* image, const std::vector<std::uint8_t>& sampled) {
  std::vector<Level> levels;
  levels.push_back(downsample_image<C>(*image, sampled));
  while (levels.back().w > 1 || levels.back().h > 1) {
    const Level& f = levels.back();
    levels.push_back(downsample<C>(
        f.w, f.h, [&](int x, int y, int c) { return f.value[(static_cast<size_t>(y) * f.w + x) * C + c]; },
        [&](int x, int y) { return f.valid[static_cast<size_t>(y) * f.w + x] != 0; }));
  }
  Level& top = levels.back();
  if (!top.valid[0]) std::fill(top.value.begin(), top.value.end(), 128.0f);
  // Pull: coarse to fine, every invalid texel takes the bilinear value of the level above.
  for (size_t k = levels.size() - 1; k-- > 0;) {
    Level& l = levels[k];
    for (int y = 0; y < l.h; ++y)
      for (int x = 0; x < l.w; ++x) {
        const size_t i = static_cast<size_t>(y) * l.w + x;
        if (!l.valid[i]) upsample<C>(levels[k + 1], x, y, &l.value[i * C]);
      }
  }
  // Level k holds 2^(k+1)-texel blocks. A 16x16 block (a JPEG MCU at 4:2:0) or an 8x8 block (a luma block) with
  // no sampled texel takes its level's value, flat: its DCT is one DC coefficient, coded as a small difference.
  const Level* l8 = levels.size() > 2 ? &levels[2] : nullptr;
  const Level* l16 = levels.size() > 3 ? &levels[3] : nullptr;
  auto flat = [](const Level* l, int x, int y, int shift) -> const float* {
    if (!l) return nullptr;
    const size_t i = static_cast<size_t>(y >> shift) * l->w + (x >> shift);
    return l->valid[i] ? nullptr : &l->value[i * C];
  };
  for (int y = 0; y < image->height; ++y)
    for (int x = 0; x < image->width; ++x) {
      if (sampled[static_cast<size_t>(y) * image->width + x]) continue;
      float v[C];
      const float* f = flat(l16, x, y, 4);
      if (!f) f = flat(l8, x, y, 3);
      if (f)
        std::copy(f, f + C, v);
      else
        upsample<C>(levels[0], x, y, v);
      std::uint8_t* px = image->pixel(x, y);
      for (int c = 0; c < C; ++c) px[c] = static_cast<std::uint8_t>(std::clamp(v[c] + 0.5f, 0.0f, 255.0f));
    }
}

}  // namespace

void mark_sampled_texels(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, int width,
                         int height, std::uint8_t* mask) {
  TriangleMarker(a, b, c, width, height).mark(mask);
}

Result<std::vector<std::uint8_t>> texels_sampled_by_uvs(const Mesh& mesh, int width, int height) {
  if (width <= 0 || height <= 0) return make_error(ErrorCode::kInvalidArgument, "sampled texels: empty texture size");
  if (mesh.uvs.size() != mesh.positions.size())
    return make_error(ErrorCode::kInvalidArgument, "sampled texels: the mesh needs one UV per position");
  std::vector<std::uint8_t> mask(static_cast<size_t>(width) * height, 0);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    Eigen::Vector2d q[3];
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t idx = mesh.indices[t + i];
      if (idx >= mesh.uvs.size())
        return make_error(ErrorCode::kInvalidArgument,
                          "sampled texels: index " + std::to_string(idx) + " out of range");
      const Eigen::Vector2f& uv = mesh.uvs[idx];
      if (!uv.allFinite()) return make_error(ErrorCode::kInvalidArgument, "sampled texels: a UV is not finite");
      q[i] = Eigen::Vector2d(double(uv.x()) * width, double(uv.y()) * height);
    }
    mark_sampled_texels(q[0], q[1], q[2], width, height, mask.data());
  }
  return mask;
}

Status fill_unsampled_texels(Image* image, const std::vector<std::uint8_t>& sampled) {
  if (!image || image->empty() || (image->channels != 3 && image->channels != 4) ||
      image->data.size() != static_cast<size_t>(image->width) * image->height * image->channels)
    return make_error(ErrorCode::kInvalidArgument, "fill: the image must be RGB8 or RGBA8");
  if (sampled.size() != static_cast<size_t>(image->width) * image->height)
    return make_error(ErrorCode::kInvalidArgument, "fill: the mask must have one entry per texel");
  if (image->channels == 3)
    push_pull<3>(image, sampled);
  else
    push_pull<4>(image, sampled);
  return ok_status();
}

}  // namespace rgbdcast
