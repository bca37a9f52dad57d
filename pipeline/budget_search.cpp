// meet_budget (realtime preset): see budget_search.h for the search's model.
#include "pipeline/budget_search.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <future>
#include <memory>

#include "atlas/texture_encode.h"
#include "atlas/unsampled_fill.h"
#include "base/stopwatch.h"
#include "base/worker_threads.h"
#include "reduction/openmp_threads.h"

namespace rgbdcast {

namespace {

// Bytes of a GLB kept for the caller's extras (stage lists, intrinsics, capture metadata) when meeting a budget.
constexpr double kExtrasReserveBytes = 1200;
constexpr int kMinQuality = kBudgetMinJpegQuality;
// The texture's floor before the outline is straightened: this quality at budget_outline_texture_scale (below it
// JPEG's blocks show; on the fr2 desk pair at 40 kB, q25 at full size gave 29.6-29.9 dB over the pixels drawn, the
// outline at 2 px and q52-53 30.9 dB).
constexpr int kOutlineFloorQuality = 30;
// Limits of what a budget may give up: the mesh's tolerance (sigma units), then its outline (the collapses' limit
// in pixels, doubled up to this), and the texture's resolution (halved down to this). A budget below what they
// allow is not met; the report says so ("over-budget").
constexpr double kMaxToleranceFactor = 32;
constexpr double kMaxSimplifyPx = 8;
constexpr double kMinTextureScale = kBudgetMinTextureScale;
// Geometry bytes per triangle of the compact GLB before one is measured, by codec: the medians of the realtime
// preset's meshes on the shared frames, with its collapses at 2 px, are 4.81 with meshopt and 3.17 with Draco
// (BENCHMARKS.md, "Geometry codecs"; 4.4 and 2.6 at 1 px). Only the first guess depends on them.
double prior_bytes_per_triangle(const GlbWriteOptions& o) {
  if (o.flavor != GlbFlavor::kCompact) return 24.0;  // float positions and UVs
  return o.geometry_codec == GeometryCodec::kDraco ? 3.2 : 4.8;
}

// libjpeg's quantizer scale for a quality (jpeg_quality_scaling), as its logarithm, and back.
double log_quantizer_scale(double q) { return std::log(q < 50 ? 5000.0 / q : 200.0 - 2.0 * q); }
double quality_of_log_scale(double x) {
  const double scale = std::exp(x);
  return scale > 100 ? 5000.0 / scale : (200.0 - scale) / 2.0;
}

Scene node_scene(const SceneNode& node, const CaptureCamera& camera) {
  Scene s;
  s.nodes.push_back(node);
  s.cameras.push_back(camera);
  return s;
}

// The texture at a resolution scale (INTER_AREA: an integer factor such as 0.5 takes OpenCV's fast path). The
// mesh's UVs are relative, so a scaled texture needs no change to them.
Image scaled_texture(const Image& full, double scale) {
  if (scale >= 1.0) return full;
  const cv::Mat src(full.height, full.width, CV_8UC3, const_cast<std::uint8_t*>(full.data.data()));
  cv::Mat small;
  cv::resize(
      src, small,
      cv::Size(std::max(1, int(std::lround(full.width * scale))), std::max(1, int(std::lround(full.height * scale)))),
      0, 0, cv::INTER_AREA);
  return image_from_rgb_mat(small);
}

// The budget's JPEGs use libjpeg's standard Huffman tables, not the image's own: a search encodes the texture 4-8
// times and keeps one of them, and the image's own tables cost each encode a second pass (encode_jpeg has the
// figures). The same bytes then buy a lower quality: 0.1-0.3 dB drawn at the capture pose
// (BENCHMARKS.md, "Realtime preset against the paper preset").
constexpr bool kBudgetOptimizesHuffman = false;

// JPEG encodes of one image at several qualities, on up to `threads` workers (base/worker_threads.h).
Result<std::vector<std::vector<std::uint8_t>>> encode_jpegs(const Image& im, const std::vector<int>& qualities,
                                                            int threads) {
  std::vector<Result<std::vector<std::uint8_t>>> out(qualities.size(), make_error(ErrorCode::kInternal, "not encoded"));
  const int workers = std::clamp(threads, 1, static_cast<int>(qualities.size()));
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i; (i = next++) < qualities.size();) out[i] = encode_jpeg(im, qualities[i], kBudgetOptimizesHuffman);
  };
  run_workers(workers, [&](int) { work(); });
  std::vector<std::vector<std::uint8_t>> bytes;
  for (auto& r : out) {
    if (!r) return r.error();
    bytes.push_back(std::move(*r));
  }
  return bytes;
}

// The frame texture of `before` (a mesh before its collapses), unfilled, and the texels its triangles sample (each
// lookup's bilinear footprint included): what a texture made beside the collapses starts from.
struct SampledTexture {
  Image texture;
  std::vector<std::uint8_t> sampled;
  double ms = 0;
};

Result<std::shared_ptr<const SampledTexture>> sample_before_collapses(const Mesh& before, const RgbdFrame& frame,
                                                                      AtlasOptions o) {
  const auto t0 = SteadyClock::now();
  o.mode = TextureMode::kFrame;
  o.fill_unsampled = false;
  o.encode = false;
  o.reorder_triangles = false;
  auto r = build_atlas(before, frame.color_rgb, frame.intrinsics.pinhole(), o);
  if (!r) return r.error();
  auto sampled = texels_sampled_by_uvs(r->mesh, r->mesh.texture.width, r->mesh.texture.height);
  if (!sampled) return sampled.error();
  auto out = std::make_shared<SampledTexture>();
  out->texture = std::move(r->mesh.texture);
  out->sampled = std::move(*sampled);
  out->ms = ms_since(t0);
  return std::shared_ptr<const SampledTexture>(std::move(out));
}

// The texture made from it for collapses that keep the surface, outline included, within simplify_px of where it
// was: its unsampled texels filled, the sampled ones grown by that much first, so the texels the collapsed mesh
// samples keep their colour. The sample is left as it was, so that collapses that go further from the same mesh
// (a second limit) start from it again instead of rasterising the same triangles anew.
Result<AtlasResult> fill_before_collapses(const SampledTexture& s, double simplify_px) {
  const auto t0 = SteadyClock::now();
  AtlasResult r;
  r.mode = TextureMode::kFrame;
  r.mesh.texture = s.texture;
  std::vector<std::uint8_t> sampled = s.sampled;
  const int w = r.mesh.texture.width, h = r.mesh.texture.height;
  const int grow = static_cast<int>(std::ceil(std::max(0.0, simplify_px)));
  cv::Mat mask(h, w, CV_8UC1, sampled.data());
  if (grow > 0) cv::dilate(mask, mask, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * grow + 1, 2 * grow + 1)));
  r.unsampled_texels = static_cast<size_t>(std::count(sampled.begin(), sampled.end(), 0));
  const auto f0 = SteadyClock::now();
  if (auto st = fill_unsampled_texels(&r.mesh.texture, sampled); !st) return st.error();
  r.fill_ms = ms_since(f0);
  r.ms = s.ms + ms_since(t0);
  return r;
}

// One frame's search. Its members are the search's state: the last measurement (bytes a triangle, the share of
// triangles kept, the rest of the GLB), the hierarchy's counts, the JPEGs tried on the current texture and the last
// mesh, kept so that a further straightening of the outline goes on from it.
class BudgetSearch {
 public:
  BudgetSearch(const BudgetInputs& in, TexturedFrame* out);
  Status run();

 private:
  using Jpegs = Result<std::vector<TriedJpeg>>;
  // The last mesh's tolerance, collapses' limit, its mesh before them and after: when the outline is straightened
  // further at the same tolerance, the collapses go on from the collapsed mesh at the new limit, not from a new
  // extraction (augmented ICL frame 0: 54 against 68 ms a frame, the same mesh within 2 % of its triangles and
  // 0.05 dB drawn; the outline then stays within the sum of the limits, moved_px, which the texture's mask grows by).
  struct LastMesh {
    double tolerance = -1, simplify_px = 0, moved_px = 0;
    Mesh before;
    ReducedFrame collapsed;
    std::shared_ptr<const SampledTexture> sampled;  // before's texture and sampled texels (a second limit's too)
  };

  Status measure_geometry(const Mesh& mesh);
  void update_total() { b.glb_bytes = b.geometry_bytes + b.texture_bytes + rest_bytes; }
  void count_triangles();
  void counts_from_tol0();
  size_t count_at(double tolerance);
  double tolerance_for(double want);
  double geometry_for(double bytes) { return tolerance_for(bytes / bytes_per_triangle); }
  Status encode_at(double scale, const std::vector<int>& qualities, int workers);
  double bytes_of(int q, double scale) const { return tried_bytes(tried, q, scale); }
  bool anticipates(double tolerance, double simplify_px);
  Result<AtlasResult> mesh_with_texture_beside(double tolerance, double simplify_px, std::vector<StageReport>* stages,
                                               Status* geometry, Jpegs* jpegs, double* limit_px);
  Status remesh(double tolerance, double simplify_px);
  Status fit_geometry();
  Status straighten_outline();
  Status give_back_to_mesh();
  Result<int> fit_quality_at(double at, double texture_target);
  Status fit_texture();

  const RgbdFrame& frame;
  const FrameReductionOptions& options;
  const Eigen::Matrix4d& camera_to_world;
  const std::vector<CoverageView>& earlier;
  const RealtimeReduction* prepared;
  const AtlasOptions& atlas;
  const TextureAtTolerance& texture_at;
  TexturedFrame& out;
  BudgetChoice& b;
  const int max_quality;   // the best JPEG quality the budget tries
  const double tol0;       // the parameters' tolerance: the finest the budget may choose
  const double simplify0;  // the parameters' collapses
  const double target;     // the node's bytes: the budget less what the caller's extras take
  const double geometry_cap;
  const DepthMeshHierarchy& hierarchy;
  const int threads;
  // With two threads and nothing to drop for earlier views, the texture is made from the mesh before its collapses
  // on a second thread (sample_before_collapses and fill_before_collapses, then its JPEGs at the best and the least
  // quality), beside the collapses and the geometry's measurement on this one.
  const bool texture_beside;
  const double speculative_tolerance;
  double bytes_per_triangle;
  double kept = 1.0;  // triangles left after dropping those earlier views cover, over those extracted
  Result<AtlasResult> textured = make_error(ErrorCode::kInternal, "not meshed");
  size_t rest_bytes = 0;  // the GLB's bytes besides geometry and texture: JSON, chunk headers, padding
  GlbWriteOptions glb_options;
  Result<ReducedFrame> speculative = make_error(ErrorCode::kInternal, "not extracted");
  DepthMeshHierarchy::TriangleCounts counts;
  // JPEG encodes tried on the current mesh's texture: (quality, scale) -> bytes. A remesh changes the texture's
  // fill, so it clears them.
  std::vector<TriedJpeg> tried;
  Image scaled;  // the texture at scaled_at < 1, made when needed
  double scaled_at = 1.0;
  LastMesh last;
};

}  // namespace

int guess_quality(int q_lo, double lo_bytes, int q_hi, double hi_bytes, double target) {
  const double f = std::log(target / lo_bytes) / std::log(hi_bytes / lo_bytes);
  const double x = log_quantizer_scale(q_lo) + f * (log_quantizer_scale(q_hi) - log_quantizer_scale(q_lo));
  return static_cast<int>(std::floor(quality_of_log_scale(x)));
}

double tried_bytes(const std::vector<TriedJpeg>& tried, int q, double scale) {
  for (const TriedJpeg& t : tried)
    if (t.quality == q && t.scale == scale) return static_cast<double>(t.bytes.size());
  return -1;
}

void narrow_to_tried(const std::vector<TriedJpeg>& tried, double scale, double target, int* q_lo, int* q_hi) {
  for (const TriedJpeg& t : tried)
    if (t.scale == scale && t.quality > *q_lo && t.quality < *q_hi) {
      if (static_cast<double>(t.bytes.size()) <= target)
        *q_lo = t.quality;
      else
        *q_hi = t.quality;
    }
}

std::vector<int> next_qualities(const std::vector<TriedJpeg>& tried, double scale, int q_lo, int q_hi, double target) {
  std::vector<int> qs;
  if (q_hi - q_lo < 2) return qs;  // nothing between them
  const int guess = guess_quality(q_lo, tried_bytes(tried, q_lo, scale), q_hi, tried_bytes(tried, q_hi, scale), target);
  for (int q : {guess - 2, guess + 2}) {
    q = std::clamp(q, q_lo + 1, q_hi - 1);
    if (std::find(qs.begin(), qs.end(), q) == qs.end()) qs.push_back(q);
  }
  return qs;
}

BudgetSearch::BudgetSearch(const BudgetInputs& in, TexturedFrame* out_frame)
    : frame(in.frame),
      options(in.options),
      camera_to_world(in.camera_to_world),
      earlier(in.earlier),
      prepared(&in.prepared),
      atlas(in.atlas),
      texture_at(in.texture_at),
      out(*out_frame),
      b(out_frame->budget),
      max_quality(in.options.budget_max_jpeg_quality),
      tol0(in.options.params.depth_mesh.tolerance_factor),
      simplify0(in.options.params.depth_mesh.simplify_px),
      target(in.budget_kb * 1000.0 - kExtrasReserveBytes),
      geometry_cap(in.options.budget_geometry_share * target),
      hierarchy(in.prepared.hierarchy),
      threads(openmp_threads(in.options.params.threads)),
      texture_beside(threads > 1 && in.earlier.empty() && in.atlas.mode == TextureMode::kFrame &&
                     in.atlas.fill_unsampled.value_or(false)),
      speculative_tolerance(DepthMeshHierarchy::TriangleCounts::bin_top_of(kMaxToleranceFactor)),
      bytes_per_triangle(prior_bytes_per_triangle(in.options.glb)),
      glb_options(in.options.glb) {
  b.budget_bytes = in.budget_kb * 1000.0;
  b.simplify_px = simplify0;
  // The GLB without its texture's bytes, which gives the geometry's bytes and the rest. The texture's stand-in is
  // a JPEG header alone (start of image, a baseline frame header of the texture's size): the UV quantization, which
  // follows the texture's size, is the final file's, so the Draco results are reused when it is written.
  if (glb_options.flavor == GlbFlavor::kCompact && glb_options.geometry_codec == GeometryCodec::kDraco)
    glb_options.draco.cache = out.geometry_cache = std::make_shared<DracoCache>();
}

Status BudgetSearch::run() {
  count_triangles();
  if (auto s = fit_geometry(); !s) return s;
  if (auto s = straighten_outline(); !s) return s;
  if (auto s = give_back_to_mesh(); !s) return s;
  return fit_texture();
}

// The GLB without its texture's bytes: the geometry's bytes and the rest.
Status BudgetSearch::measure_geometry(const Mesh& mesh) {
  SceneNode probe;  // the geometry and the stand-in (its header gives the texture's size): no pixel copy
  probe.mesh.positions = mesh.positions;
  probe.mesh.uvs = mesh.uvs;
  probe.mesh.indices = mesh.indices;
  const int tw = mesh.texture.width, th = mesh.texture.height;
  probe.mesh.texture_encoded = {0xFF,
                                0xD8,
                                0xFF,
                                0xC0,
                                0x00,
                                0x0B,
                                0x08,
                                static_cast<std::uint8_t>(th >> 8),
                                static_cast<std::uint8_t>(th & 0xFF),
                                static_cast<std::uint8_t>(tw >> 8),
                                static_cast<std::uint8_t>(tw & 0xFF),
                                0x01,
                                0x01,
                                0x11,
                                0x00};
  probe.mesh.texture_mime = "image/jpeg";
  probe.to_world = camera_to_world;
  GlbStats st;
  auto glb = encode_glb(node_scene(probe, out.camera), glb_options, &st);
  if (!glb) return glb.error();
  b.geometry_bytes = st.geometry_bytes;
  rest_bytes = glb->size() - st.geometry_bytes - std::min(glb->size() - st.geometry_bytes, st.texture_bytes);
  return ok_status();
}

// The smallest tolerance >= tol0 whose mesh has at most `want` triangles, from the counts at every tolerance
// (one walk of the hierarchy). The walk starts at kCountsFirstSigma: it visits every triangle whose parent's error
// is above its minimum, and the budget rarely goes below it (every shared frame at 40 kB ends at the largest
// tolerance), so the walk from tol0 is made only when a tolerance below it is asked for. The counts above the
// minimum are the same either way (TriangleCounts: a triangle counts where own <= t < parent).
// Beside the walk, on the second thread, the mesh at the largest tolerance is extracted: every shared frame's first
// mesh at 40 kB is that one (its geometry is over its share at any tolerance), so its extraction leaves the
// critical path; a first mesh at another tolerance is extracted when it is asked for, as before.
void BudgetSearch::count_triangles() {
  constexpr double kCountsFirstSigma = 8;
  BesideThread side;
  if (texture_beside) side.start([&] { speculative = extract_realtime(*prepared, frame, speculative_tolerance, 0); });
  counts = hierarchy.counts(std::max(tol0, kCountsFirstSigma), texture_beside ? 1 : threads);
  side.join();
}

void BudgetSearch::counts_from_tol0() {
  if (counts.minimum() > tol0) counts = hierarchy.counts(tol0, threads);
}

size_t BudgetSearch::count_at(double tolerance) {
  if (tolerance < counts.minimum()) counts_from_tol0();
  return counts.at(tolerance);
}

double BudgetSearch::tolerance_for(double want) {
  double t = counts.smallest_with_at_most(want / kept, kMaxToleranceFactor);
  if (t <= counts.minimum() && counts.minimum() > tol0) {  // the answer may lie below this walk's minimum
    counts_from_tol0();
    t = counts.smallest_with_at_most(want / kept, kMaxToleranceFactor);
  }
  return t;
}

Status BudgetSearch::encode_at(double scale, const std::vector<int>& qualities, int workers) {
  if (scale < 1.0 && scaled_at != scale) {
    scaled = scaled_texture(textured->mesh.texture, scale);
    scaled_at = scale;
  }
  auto bytes = encode_jpegs(scale < 1.0 ? scaled : textured->mesh.texture, qualities, workers);
  if (!bytes) return bytes.error();
  for (size_t i = 0; i < qualities.size(); ++i) tried.push_back({qualities[i], scale, std::move((*bytes)[i])});
  b.encodes += static_cast<int>(qualities.size());
  return ok_status();
}

// Past the largest tolerance the outline may have to be straightened at twice the limit (straighten_outline). The
// mesh at the largest tolerance anticipates it: its texture's mask allows for the further collapses, the texture's
// floor (kOutlineFloorQuality) is encoded beside, and when the collapsed mesh's bytes, estimated from its triangles
// at the last measured bytes a triangle, leave the floor no room, the collapses go on at twice the limit before the
// geometry is measured: one geometry encode and one texture instead of two (augmented ICL, fr3).
// It does so only when the extracted mesh is far over the geometry's share: at kKeptPrior of its triangles after
// the collapses (they keep 0.71 on TUM fr1/xyz 200-319 frame 0, 0.33 on augmented ICL frame 0, both at 32 sigma
// and 1 px), so a mesh the collapses bring under the share keeps the mask of its own collapses and its texture's
// bytes.
constexpr double kKeptPrior = 0.75;
bool BudgetSearch::anticipates(double tolerance, double simplify_px) {
  return tolerance >= kMaxToleranceFactor && simplify_px > 0 && 2 * simplify_px <= kMaxSimplifyPx &&
         options.budget_outline_texture_scale == 1.0 &&
         static_cast<double>(count_at(tolerance)) * kKeptPrior * bytes_per_triangle > 1.1 * geometry_cap;
}

constexpr double kRestPriorBytes = 1500;  // the GLB's JSON and headers before a first measurement
// The mesh at a tolerance, textured, its geometry measured into *geometry (Draco or meshopt, in a GLB) and, beside it
// on a second thread, its texture's JPEGs at max_quality and kMinQuality (and kOutlineFloorQuality when it
// anticipates) into *jpegs (the search that may follow needs both); the collapses' limit it ended at into *limit_px.
Result<AtlasResult> BudgetSearch::mesh_with_texture_beside(double tolerance, double simplify_px,
                                                           std::vector<StageReport>* stages, Status* geometry,
                                                           Jpegs* jpegs, double* limit_px) {
  const bool go_on = tolerance == last.tolerance && simplify_px > last.simplify_px && last.simplify_px > 0;
  const bool use_speculative = !go_on && speculative && tolerance == speculative_tolerance;
  Result<ReducedFrame> reduced = go_on             ? Result<ReducedFrame>(std::move(last.collapsed))
                                 : use_speculative ? std::move(speculative)
                                                   : extract_realtime(*prepared, frame, tolerance, 0);
  if (use_speculative) speculative = make_error(ErrorCode::kInternal, "used");
  if (!reduced) return reduced.error();
  Mesh before;
  if (go_on) {
    before = std::move(last.before);
  } else {
    before.positions = reduced->mesh.positions;
    before.indices = reduced->mesh.indices;
  }
  Result<AtlasResult> side_texture = make_error(ErrorCode::kInternal, "not made");
  double moved_px = go_on ? last.moved_px + simplify_px : simplify_px;    // the outline's bound
  const bool anticipate = !go_on && anticipates(tolerance, simplify_px);  // (a further pass: the loop's)
  const double mask_px = anticipate ? moved_px + 2 * simplify_px : moved_px;
  std::promise<double> floor_bytes;  // the texture's floor JPEG, when anticipated (-1: none)
  std::future<double> floor_ready = floor_bytes.get_future();
  // The texture's bytes left once the collapsed mesh's geometry is estimated (its triangles at the last measured
  // bytes a triangle): the second thread encodes a first step of the quality search for it while this one
  // measures the geometry (-1: none).
  std::promise<double> predicted_left;
  std::future<double> predicted_ready = predicted_left.get_future();
  bool predicted_set = false;
  auto predict = [&](double value) {
    if (!predicted_set) predicted_left.set_value(value);
    predicted_set = true;
  };
  std::shared_ptr<const SampledTexture> sample = go_on ? last.sampled : nullptr;
  BesideThread side([&] {
    if (!sample) {
      auto made = sample_before_collapses(before, frame, atlas);
      if (made)
        sample = std::move(*made);
      else
        side_texture = made.error();
    }
    if (sample) side_texture = fill_before_collapses(*sample, mask_px);
    if (!side_texture) {
      floor_bytes.set_value(-1);
      *jpegs = side_texture.error();
      return;
    }
    const Image& im = side_texture->mesh.texture;
    std::vector<TriedJpeg> out;
    auto add = [&](const std::vector<int>& qualities) -> Status {
      auto bytes = encode_jpegs(im, qualities, 1);
      if (!bytes) return bytes.error();
      for (size_t i = 0; i < qualities.size(); ++i) out.push_back({qualities[i], 1.0, std::move((*bytes)[i])});
      return ok_status();
    };
    Status st = ok_status();
    if (anticipate) {
      st = add({kOutlineFloorQuality});
      floor_bytes.set_value(st ? static_cast<double>(out.back().bytes.size()) : -1);
    } else {
      floor_bytes.set_value(-1);
    }
    if (st) st = add({max_quality, kMinQuality});
    if (!st) {
      *jpegs = st.error();
      return;
    }
    const double left = predicted_ready.get();
    if (left > tried_bytes(out, kMinQuality, 1.0) && left < tried_bytes(out, max_quality, 1.0)) {
      int q_lo = kMinQuality, q_hi = max_quality;
      narrow_to_tried(out, 1.0, left, &q_lo, &q_hi);
      const std::vector<int> qs = next_qualities(out, 1.0, q_lo, q_hi, left);
      if (!qs.empty()) st = add(qs);
    }
    if (st)
      *jpegs = std::move(out);
    else
      *jpegs = st.error();
  });
  double limit = simplify_px;
  Result<AtlasResult> t = [&]() -> Result<AtlasResult> {
    if (auto st = simplify_realtime(*prepared, frame, simplify_px, &*reduced); !st) return st.error();
    const double rest = rest_bytes > 0 ? static_cast<double>(rest_bytes) : kRestPriorBytes;
    auto estimate_geometry = [&] { return static_cast<double>(reduced->mesh.triangle_count()) * bytes_per_triangle; };
    if (anticipate) {
      const double estimate = estimate_geometry();
      if (estimate > 1.1 * geometry_cap) {
        const double floor = floor_ready.get();
        if (floor > 0 && estimate + rest + floor > target) {
          limit = 2 * simplify_px;
          moved_px += limit;
          if (auto st = simplify_realtime(*prepared, frame, limit, &*reduced); !st) return st.error();
        }
      }
    }
    predict(target - estimate_geometry() - rest);
    // One "simplify" stage: every pass's time, the last count.
    std::vector<StageReport> merged;
    for (StageReport& r : reduced->stages) {
      auto first =
          std::find_if(merged.begin(), merged.end(), [](const StageReport& m) { return m.name == "simplify"; });
      if (r.name == "simplify" && first != merged.end()) {
        first->ms += r.ms;
        first->count = r.count;
      } else {
        merged.push_back(std::move(r));
      }
    }
    reduced->stages = std::move(merged);
    AtlasOptions o = atlas;
    o.fill_unsampled = false;
    o.encode = false;
    auto uvs = build_atlas(reduced->mesh, frame.color_rgb, frame.intrinsics.pinhole(), o);
    if (!uvs) return uvs.error();
    *geometry = measure_geometry(uvs->mesh);
    return uvs;
  }();
  predict(-1);  // (when the collapses failed)
  side.join();
  last.tolerance = t ? tolerance : -1;
  last.simplify_px = limit;
  last.moved_px = moved_px;
  last.before = std::move(before);
  last.sampled = std::move(sample);
  *limit_px = limit;
  if (!t) return t.error();
  if (!side_texture) return side_texture.error();
  t->mesh.texture = std::move(side_texture->mesh.texture);
  t->unsampled_texels = side_texture->unsampled_texels;
  t->fill_ms = side_texture->fill_ms;
  t->ms = side_texture->ms;
  *stages = reduced->stages;
  stages->push_back({"atlas", "texels", t->texels, t->ms});  // on the second thread
  last.collapsed = std::move(*reduced);
  return t;
}

// The mesh at a tolerance, textured (pixels only) and its geometry measured; then its texture at the best quality.
Status BudgetSearch::remesh(double tolerance, double simplify_px) {
  std::vector<StageReport> stages;
  Status geometry = ok_status(), texture = ok_status();
  Jpegs side_jpegs = make_error(ErrorCode::kInternal, "not encoded");
  double limit_px = simplify_px;
  auto t = texture_beside ? mesh_with_texture_beside(tolerance, simplify_px, &stages, &geometry, &side_jpegs, &limit_px)
                          : texture_at(tolerance, simplify_px, &stages);
  if (!t) return t.error();
  const double extracted = static_cast<double>(count_at(tolerance));
  const double triangles = static_cast<double>(t->mesh.triangle_count());
  kept = extracted > 0 ? std::max(0.05, triangles / extracted) : 1.0;
  textured = std::move(t);
  ++b.meshes;
  out.stages = std::move(stages);
  b.tolerance_factor = tolerance;
  b.simplify_px = limit_px;
  tried.clear();
  scaled = Image{};
  scaled_at = 1.0;
  auto encode_texture = [&](int workers) { texture = encode_at(1.0, {max_quality, kMinQuality}, workers); };
  if (texture_beside) {  // both measured already
    if (!side_jpegs) return side_jpegs.error();
    b.encodes += static_cast<int>(side_jpegs->size());
    for (TriedJpeg& j : *side_jpegs) tried.push_back(std::move(j));
  } else if (threads > 1) {
    BesideThread side([&] { geometry = measure_geometry(textured->mesh); });
    encode_texture(1);
    side.join();
  } else {
    geometry = measure_geometry(textured->mesh);
    encode_texture(1);
  }
  ++b.encodes;  // the geometry's
  if (!geometry) return geometry;
  if (!texture) return texture;
  b.texture_bytes = static_cast<size_t>(bytes_of(max_quality, 1.0));
  update_total();
  bytes_per_triangle = static_cast<double>(b.geometry_bytes) / std::max(1.0, triangles);
  return ok_status();
}

Status BudgetSearch::fit_geometry() {
  b.jpeg_quality = max_quality;
  if (auto s = remesh(geometry_for(geometry_cap), simplify0); !s) return s.error();
  // One correction when the prior was off by more than 10 %.
  if (b.geometry_bytes > 1.1 * geometry_cap && b.tolerance_factor < kMaxToleranceFactor)
    if (auto s = remesh(geometry_for(geometry_cap), simplify0); !s) return s.error();
  b.rule = b.simplify_px > simplify0   ? "outline-capped"
           : b.tolerance_factor > tol0 ? "geometry-capped"
                                       : "texture-fitted";
  return ok_status();
}

// Past the largest tolerance the mesh's bytes are its outline's (depth jumps and holes, which split whatever the
// tolerance). When they leave the texture less than its floor (kOutlineFloorQuality at
// budget_outline_texture_scale, full resolution by default), the collapses straighten the outline further, their
// limit doubled until they do not. The outline then stays within that many pixels of the depth's (a few of its
// pixels uncovered, so the geometry keeps more than its share before it comes to this); the texture gets what is
// left, as below. This holds at the largest tolerance whether or not the geometry is over its share: a mesh within
// its share can still leave the texture under its floor (TUM fr1/xyz frame 0 at 40 kB: q24 at 2 px, 29.69 dB drawn
// at the capture pose; with this rule 4 px q42, 30.56 dB; BENCHMARKS.md, "Realtime preset against the paper preset"),
// but only up to kFloorSimplifyPx: further straightening costs more coverage than a better texture gains (TUM fr1/xyz
// 200-319 frame 0 at 20 kB went to 8 px: coverage 0.9968 -> 0.9889, all-valid PSNR 26.69 -> 23.35 dB). Whether the
// floor fits is read off the encodes tried when they decide it (one at or above the floor that fits, or one at or below
// it that does not), so a frame whose texture is well above its floor pays no encode for the check.
Status BudgetSearch::straighten_outline() {
  constexpr double kFloorSimplifyPx = 4;
  while (b.tolerance_factor >= kMaxToleranceFactor && simplify0 > 0 && b.simplify_px < kMaxSimplifyPx &&
         (b.geometry_bytes > 1.1 * geometry_cap || 2 * b.simplify_px <= kFloorSimplifyPx)) {
    const double kept_scale = options.budget_outline_texture_scale;
    const double texture_left = target - static_cast<double>(b.geometry_bytes + rest_bytes);
    auto tried_any = [&](auto pred) {
      return std::any_of(tried.begin(), tried.end(), [&](const TriedJpeg& t) {
        return t.scale == kept_scale && pred(t.quality, static_cast<double>(t.bytes.size()));
      });
    };
    bool fits = tried_any([&](int q, double bytes) { return q >= kOutlineFloorQuality && bytes <= texture_left; });
    if (!fits && !tried_any([&](int q, double bytes) { return q <= kOutlineFloorQuality && bytes > texture_left; })) {
      if (auto s = encode_at(kept_scale, {kOutlineFloorQuality}, 1); !s) return s.error();
      fits = bytes_of(kOutlineFloorQuality, kept_scale) <= texture_left;
    }
    if (fits) break;
    if (auto s = remesh(b.tolerance_factor, std::min(kMaxSimplifyPx, 2 * b.simplify_px)); !s) return s.error();
    b.rule = "outline-capped";
  }
  return ok_status();
}

Status BudgetSearch::give_back_to_mesh() {
  if (b.glb_bytes <= target && b.simplify_px == simplify0) {
    // The texture at its best quality leaves bytes over: they go back to the mesh (at most twice: the bytes a
    // triangle costs, and the share of triangles the collapses keep, change with the tolerance).
    for (int round = 0; round < 2; ++round) {
      const double left = target - static_cast<double>(b.glb_bytes);
      if (left <= 0.05 * target || b.tolerance_factor <= tol0) break;
      const double before = b.tolerance_factor;
      if (auto s = remesh(geometry_for(static_cast<double>(b.geometry_bytes) + 0.9 * left), simplify0); !s)
        return s.error();
      if (b.tolerance_factor == before) break;
    }
    if (b.tolerance_factor <= tol0 && b.glb_bytes <= target) b.rule = "fits";
  }
  return ok_status();
}

// The largest quality at `at` whose bytes fit texture_target: max_quality when it fits, kMinQuality when nothing
// does (the caller then goes down in scale).
Result<int> BudgetSearch::fit_quality_at(double at, double texture_target) {
  int lo = kMinQuality, hi = max_quality;  // bytes at hi (at this scale) do not fit
  if (bytes_of(lo, at) < 0 || bytes_of(hi, at) < 0)
    if (auto s = encode_at(at, {kMinQuality, max_quality}, threads); !s) return s.error();
  if (bytes_of(hi, at) <= texture_target) return hi;  // at a reduced resolution the best quality fits
  if (bytes_of(lo, at) > texture_target) return lo;
  // The closest qualities already tried (the floor's and the second thread's first step) bracket it.
  narrow_to_tried(tried, at, texture_target, &lo, &hi);
  for (int step = 0; step < 3 && hi - lo > 1 && bytes_of(lo, at) < 0.95 * texture_target; ++step) {
    const std::vector<int> qs = next_qualities(tried, at, lo, hi, texture_target);
    if (auto s = encode_at(at, qs, threads); !s) return s.error();
    for (int q : qs) {
      if (bytes_of(q, at) <= texture_target)
        lo = std::max(lo, q);
      else
        hi = std::min(hi, q);
    }
    if (hi <= lo) break;  // JPEG bytes are not quite monotone in the quality: lo fits, which is enough
  }
  return lo;
}

// Texture: the largest quality (at full resolution, else at budget_outline_texture_scale when that is between a
// half and 1, else the largest of half, quarter... down to kMinTextureScale where the least quality fits) whose
// bytes fit what is left. The outline was kept for the texture at its scale (kOutlineFloorQuality fitting there),
// so the texture is tried there before it is halved. JPEG bytes follow a power of
// libjpeg's quantizer scale (5000 / q below 50, 200 - 2 q above): on six realtime textures (TUM fr1/xyz 200-319
// frames 0 and 60, fr3, augmented ICL, ICL-NUIM, a PCL PCD) log bytes normalised over q20..q92 stay within 0.06
// of log scale normalised the same way, where a line in the quality is off by up to 0.13 (6 steps at q50). So the
// quality is interpolated on log bytes against log scale between the closest qualities tried on either side and
// refined (two encodes a step, on two threads) until within 5 % under what is left, at most three times.
Status BudgetSearch::fit_texture() {
  const double texture_target = target - static_cast<double>(b.glb_bytes - b.texture_bytes);
  double scale = 1.0;
  int q_lo = max_quality;
  if (static_cast<double>(b.texture_bytes) > texture_target) {
    const double outline_scale = options.budget_outline_texture_scale;
    for (;;) {
      auto q = fit_quality_at(scale, texture_target);
      if (!q) return q.error();
      q_lo = *q;
      if (bytes_of(q_lo, scale) <= texture_target || scale <= kMinTextureScale) break;  // fits, or the last scale
      // The least quality does not fit: the outline's scale, when below this one, else half of this one.
      scale = scale == 1.0 && outline_scale < 1.0 && outline_scale > 0.5 ? outline_scale
              : scale < 1.0 && scale > 0.5                               ? 0.5
                                                                         : scale / 2;
    }
  }
  for (TriedJpeg& t : tried)
    if (t.quality == q_lo && t.scale == scale) {
      if (scale < 1.0) textured->mesh.texture = std::move(scaled);
      textured->mesh.texture_encoded = std::move(t.bytes);
      textured->mesh.texture_mime = "image/jpeg";
      break;
    }
  b.jpeg_quality = q_lo;
  b.texture_scale = scale;
  b.texture_bytes = textured->mesh.texture_encoded.size();
  // UVs are quantized to the texture's size, so a smaller texture changes the geometry's bytes: measured again.
  if (scale < 1.0) {
    if (auto s = measure_geometry(textured->mesh); !s) return s.error();
    ++b.encodes;
  }
  update_total();
  if (b.glb_bytes > 1.1 * target) b.rule = "over-budget";
  out.node.mesh = std::move(textured->mesh);
  out.atlas_stats = std::move(*textured);
  out.atlas_stats.mesh = Mesh{};
  return ok_status();
}

Status meet_budget(const BudgetInputs& in, TexturedFrame* out) {
  const auto t0 = SteadyClock::now();
  BudgetSearch search(in, out);
  if (auto s = search.run(); !s) return s;
  out->stages.push_back({"budget", "bytes", out->budget.glb_bytes, ms_since(t0)});
  return ok_status();
}

}  // namespace rgbdcast
