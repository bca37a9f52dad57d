// KHR_draco_mesh_compression (gltf/draco_buffers.h) on real frames of ../shared/data reduced with the realtime preset:
// the decoded mesh equals the encoded one within the quantization step (same triangles, texture bytes unchanged),
// the Khronos validator reports nothing, and hostile Draco data is refused before Draco allocates for it.
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <new>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "base/atomic_file.h"
#include "gltf/draco_buffers.h"
#include "gltf/draco_header.h"
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "pipeline/frame_scene.h"
#include "tests/common/gltf_validator.h"
#include "tests/common/test_data.h"

// Heap bytes in use and their peak, counted for every operator new of the process (libdraco's included: it calls
// libstdc++'s operator new, which this definition replaces). The nothrow forms are replaced too: libstdc++'s own
// forward to operator new(size_t), but under ASan libasan defines them with its own allocator, and a block from it
// reached the free() below (std::stable_sort's buffer: ASan alloc-dealloc-mismatch in scripts/sanitize.sh).
namespace {
std::atomic<size_t> g_in_use{0}, g_peak{0};
void count_alloc(void* p) {
  if (!p) return;
  const size_t now = g_in_use += malloc_usable_size(p);
  size_t peak = g_peak.load();
  while (now > peak && !g_peak.compare_exchange_weak(peak, now)) {}
}
}  // namespace
void* operator new(size_t n) {
  void* p = std::malloc(n ? n : 1);
  if (!p) throw std::bad_alloc();
  count_alloc(p);
  return p;
}
void* operator new[](size_t n) { return operator new(n); }
void operator delete(void* p) noexcept {
  if (p) g_in_use -= malloc_usable_size(p);
  std::free(p);
}
void operator delete[](void* p) noexcept { operator delete(p); }
void operator delete(void* p, size_t) noexcept { operator delete(p); }
void operator delete[](void* p, size_t) noexcept { operator delete(p); }
void* operator new(size_t n, const std::nothrow_t&) noexcept {
  void* p = std::malloc(n ? n : 1);
  count_alloc(p);
  return p;
}
void* operator new[](size_t n, const std::nothrow_t& tag) noexcept { return operator new(n, tag); }
void operator delete(void* p, const std::nothrow_t&) noexcept { operator delete(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { operator delete(p); }

using namespace rgbdcast;
using nlohmann::json;

namespace {

// A shared frame reduced with the realtime preset at its default budget, as one node with its camera.
Scene realtime_scene(const std::string& path, size_t index) {
  SourceOptions so;
  if (path.rfind("tum/", 0) == 0) so.intrinsics = "fr1";
  auto src = open_frame_source(test::data_path(path), so);
  EXPECT_TRUE(src) << path << ": " << src.error().message;
  if (!src) return {};
  auto frame = (*src)->frame(index);
  EXPECT_TRUE(frame) << frame.error().message;
  FrameReductionOptions o;
  o.params = reduction_preset(Preset::kRealtime);
  o.budget_kb = 40;
  auto t = reduce_and_texture(*frame, o);
  EXPECT_TRUE(t) << t.error().message;
  return t ? frame_scene(std::move(*t), "{}") : Scene{};
}

GlbWriteOptions draco_options() {
  GlbWriteOptions w;
  w.geometry_codec = GeometryCodec::kDraco;
  return w;
}

json json_of(const std::vector<std::uint8_t>& glb) {
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  return chunks ? json::parse(chunks->json, nullptr, false) : json();
}

// Nearest original vertex (position + uv) of every decoded one, through a 1 cm hash grid; -1 when none is within
// the tolerances.
std::vector<long> match_vertices(const Mesh& original, const Mesh& decoded, double pos_tol, double uv_tol) {
  auto cell = [](const Eigen::Vector3f& p) {
    return std::array<long, 3>{long(std::floor(p.x() / 0.01)), long(std::floor(p.y() / 0.01)),
                               long(std::floor(p.z() / 0.01))};
  };
  std::map<std::array<long, 3>, std::vector<size_t>> grid;
  for (size_t i = 0; i < original.positions.size(); ++i) grid[cell(original.positions[i])].push_back(i);
  std::vector<long> match(decoded.positions.size(), -1);
  for (size_t j = 0; j < decoded.positions.size(); ++j) {
    const auto c = cell(decoded.positions[j]);
    double best = 1e9;
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          auto it = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == grid.end()) continue;
          for (size_t i : it->second) {
            const double dp = (original.positions[i] - decoded.positions[j]).cast<double>().lpNorm<Eigen::Infinity>();
            const double du = (original.uvs[i] - decoded.uvs[j]).cast<double>().lpNorm<Eigen::Infinity>();
            if (dp <= pos_tol && du <= uv_tol && dp + du < best) best = dp + du, match[j] = static_cast<long>(i);
          }
        }
  }
  return match;
}

// Each original vertex's representative: the lowest index among the original vertices within pos_tol and uv_tol of
// it, transitively. Vertices that close are one point once quantized (the realtime preset's boundary push can bring
// a pushed vertex within a millimetre of its neighbour), so a decoded point may stand for either.
std::vector<long> representatives(const Mesh& m, double pos_tol, double uv_tol) {
  std::vector<long> rep(m.positions.size());
  for (size_t i = 0; i < rep.size(); ++i) rep[i] = static_cast<long>(i);
  std::function<long(long)> find = [&](long i) { return rep[i] == i ? i : rep[i] = find(rep[i]); };
  for (size_t i = 0; i < m.positions.size(); ++i)
    for (size_t j = i + 1; j < m.positions.size(); ++j) {
      if ((m.positions[i] - m.positions[j]).cast<double>().lpNorm<Eigen::Infinity>() > pos_tol) continue;
      if ((m.uvs[i] - m.uvs[j]).cast<double>().lpNorm<Eigen::Infinity>() > uv_tol) continue;
      const long a = find(static_cast<long>(i)), b = find(static_cast<long>(j));
      rep[std::max(a, b)] = std::min(a, b);
    }
  for (size_t i = 0; i < rep.size(); ++i) rep[i] = find(static_cast<long>(i));
  return rep;
}

std::set<std::array<long, 3>> triangle_set(const std::vector<std::uint32_t>& idx, const std::vector<long>* map) {
  std::set<std::array<long, 3>> t;
  for (size_t i = 0; i + 2 < idx.size(); i += 3) {
    std::array<long, 3> f;
    for (int k = 0; k < 3; ++k) f[k] = map ? (*map)[idx[i + k]] : long(idx[i + k]);
    std::rotate(f.begin(), std::min_element(f.begin(), f.end()), f.end());  // winding kept
    t.insert(f);
  }
  return t;
}

struct SharedFrame {
  const char* path;
  size_t index;
};
const SharedFrame kFrames[] = {{"tum/rgbd_dataset_freiburg1_xyz", 0}, {"icl_nuim_livingroom", 0}};

TEST(GltfDraco, RealFramesRoundTripWithinTheQuantizationStep) {
  for (const SharedFrame& f : kFrames) {
    REQUIRE_DATA(f.path);
    const Scene scene = realtime_scene(f.path, f.index);
    ASSERT_EQ(scene.nodes.size(), 1u);
    const Mesh& m = scene.nodes[0].mesh;
    ASSERT_GT(m.triangle_count(), 1000u) << f.path;
    GlbStats meshopt_stats, draco_stats;
    auto meshopt = encode_glb(scene, {}, &meshopt_stats);
    auto glb = encode_glb(scene, draco_options(), &draco_stats);
    ASSERT_TRUE(glb) << glb.error().message;
    ASSERT_TRUE(meshopt) << meshopt.error().message;
    EXPECT_LT(draco_stats.geometry_bytes, meshopt_stats.geometry_bytes * 3 / 4) << f.path;
    const json doc = json_of(*glb);
    EXPECT_EQ(doc["extensionsRequired"], json::array({"KHR_draco_mesh_compression"})) << doc["extensionsRequired"];
    ASSERT_EQ(doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"].size(), 2u);
    for (const auto& acc : doc["accessors"]) EXPECT_FALSE(acc.contains("bufferView")) << acc;

    auto back = decode_glb(glb->data(), glb->size());
    ASSERT_TRUE(back) << back.error().message;
    ASSERT_EQ(back->nodes.size(), 1u);
    const Mesh& d = back->nodes[0].mesh;
    EXPECT_EQ(d.triangle_count(), m.triangle_count()) << f.path;
    // Draco's edgebreaker gives each non-manifold vertex one point per fan: a few more points, each equal to an
    // original one (the realtime preset's edge collapses leave vertices where two fans touch: 27 of 1,928 on
    // ICL-NUIM frame 0).
    EXPECT_GE(d.positions.size(), m.positions.size()) << f.path;
    EXPECT_LE(d.positions.size(), m.positions.size() + m.positions.size() / 25) << f.path;
    EXPECT_EQ(d.texture_encoded, m.texture_encoded) << "texture bytes changed";
    EXPECT_EQ(d.texture.width, m.texture.width);
    // Quantization steps after the rule (draco_buffers.h): position <= 1 mm, uv <= 0.25 texel; errors <= half.
    const double tex_side = std::max(m.texture.width, m.texture.height);
    const double pos_tol = 0.0005 + 1e-6, uv_tol = 0.125 / tex_side + 1e-7;
    auto match = match_vertices(m, d, pos_tol, uv_tol);
    EXPECT_EQ(std::count(match.begin(), match.end(), -1L), 0) << f.path
                                                              << ": decoded vertices off by more than "
                                                                 "half a step";
    // Originals closer than a step (2 x the half step) are one point after quantization: compared as one.
    const std::vector<long> rep = representatives(m, 2 * pos_tol, 2 * uv_tol);
    const size_t distinct = std::set<long>(rep.begin(), rep.end()).size();
    EXPECT_GE(distinct, m.positions.size() - m.positions.size() / 200) << f.path << ": too many twins";
    for (long& j : match)
      if (j >= 0) j = rep[j];
    EXPECT_EQ(std::set<long>(match.begin(), match.end()).size(), distinct) << "an original vertex is lost";
    EXPECT_EQ(triangle_set(d.indices, &match), triangle_set(m.indices, &rep)) << f.path << ": triangles differ";
    // The node's placement and the capture camera survive.
    EXPECT_TRUE(back->nodes[0].to_world.isApprox(scene.nodes[0].to_world, 1e-9));
    ASSERT_EQ(back->cameras.size(), 1u);
    EXPECT_DOUBLE_EQ(back->cameras[0].intrinsics.fx, scene.cameras[0].intrinsics.fx);
  }
}

// The accessors' counts and POSITION bounds are what a reader decodes. They come from the encoder, without a
// decode, when every point is referenced (a non-manifold vertex's extra points included), and from a decode when a
// point is not (the edgebreaker drops it, so the decoded bounds may be tighter than the input's).
TEST(GltfDraco, AccessorCountsAndBoundsAreTheDecodedOnes) {
  const SharedFrame frames[] = {kFrames[0],
                                kFrames[1],
                                {"tum/rgbd_dataset_freiburg1_xyz_200_319", 60},
                                {"augmented_icl_livingroom", 0},
                                {"tum/rgbd_dataset_freiburg3_long_office_household", 0}};
  for (const SharedFrame& f : frames) {
    REQUIRE_DATA(f.path);
    Scene scene = realtime_scene(f.path, f.index);
    for (bool unreferenced : {false, true}) {
      SCOPED_TRACE(std::string(f.path) + (unreferenced ? ", with an unreferenced point" : ""));
      Mesh& m = scene.nodes[0].mesh;
      if (unreferenced) {  // far outside the mesh: the input's bounds would include it, the decoded ones do not
        Eigen::Vector3f far = m.positions[0];
        for (const Eigen::Vector3f& p : m.positions) far = far.cwiseMax(p);
        m.positions.push_back(far + Eigen::Vector3f(1, 1, 1));
        m.uvs.push_back(m.uvs[0]);
      }
      auto glb = encode_glb(scene, draco_options());
      ASSERT_TRUE(glb) << glb.error().message;
      const json doc = json_of(*glb);
      const json& prim = doc["meshes"][0]["primitives"][0];
      const json& pos = doc["accessors"][prim["attributes"]["POSITION"].get<size_t>()];
      auto back = decode_glb(glb->data(), glb->size());
      ASSERT_TRUE(back) << back.error().message;
      const Mesh& d = back->nodes[0].mesh;
      EXPECT_EQ(pos["count"].get<size_t>(), d.positions.size());
      EXPECT_EQ(doc["accessors"][prim["indices"].get<size_t>()]["count"].get<size_t>(), d.indices.size());
      ASSERT_FALSE(d.positions.empty());
      for (int c = 0; c < 3; ++c) {
        double lo = d.positions[0][c], hi = lo;
        for (const Eigen::Vector3f& p : d.positions) lo = std::min<double>(lo, p[c]), hi = std::max<double>(hi, p[c]);
        EXPECT_EQ(pos["min"][c].get<double>(), lo) << "axis " << c;
        EXPECT_EQ(pos["max"][c].get<double>(), hi) << "axis " << c;
      }
      if (unreferenced) {
        for (int c = 0; c < 3; ++c) EXPECT_LT(pos["max"][c].get<double>(), m.positions.back()[c]) << "axis " << c;
      }
    }
  }
}

TEST(GltfDraco, EverySpeedDecodesBothDracoMethods) {
  // Speeds 0-9 use the edgebreaker (0: its valence coder), 10 the sequential coder: both header layouts are read.
  const SharedFrame& f = kFrames[0];
  REQUIRE_DATA(f.path);
  const Scene scene = realtime_scene(f.path, f.index);
  for (int speed : {0, 5, 7, 10}) {
    GlbWriteOptions w = draco_options();
    w.draco.encode_speed = w.draco.decode_speed = speed;
    auto glb = encode_glb(scene, w);
    ASSERT_TRUE(glb) << glb.error().message;
    auto chunks = glb::parse_glb(glb->data(), glb->size());
    const json doc = json::parse(chunks->json);
    const json& v =
        doc["bufferViews"]
           [doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"].get<size_t>()];
    auto header = glb::read_draco_header(chunks->bin.data() + v.value("byteOffset", size_t(0)), v["byteLength"]);
    ASSERT_TRUE(header) << header.error().message;
    EXPECT_EQ(header->edgebreaker, speed < 10) << "speed " << speed;
    auto back = decode_glb(glb->data(), glb->size());
    ASSERT_TRUE(back) << "speed " << speed << ": " << back.error().message;
    EXPECT_EQ(back->nodes[0].mesh.triangle_count(), scene.nodes[0].mesh.triangle_count()) << "speed " << speed;
  }
}

TEST(GltfDraco, ValidatorReportsNoErrorOrWarning) {
  const SharedFrame& f = kFrames[0];
  REQUIRE_DATA(f.path);
  auto glb = encode_glb(realtime_scene(f.path, f.index), draco_options());
  ASSERT_TRUE(glb) << glb.error().message;
  const std::string dir = test::temp_dir("draco_validator");
  const std::string path = dir + "/frame.glb";
  ASSERT_TRUE(write_file_atomically(path, *glb));
  EXPECT_GLTF_VALID(path);
  test::remove_tree_quietly(dir);
}

// The byte budget measures a frame's geometry and the GLB is written after it (pipeline/frame_scene.h): with the
// budget's DracoCache the file is byte for byte the one written without it, and the cache answered (its entry is
// the one the budget measured).
TEST(GltfDraco, TheBudgetsCacheWritesTheSameFile) {
  const SharedFrame& f = kFrames[0];
  REQUIRE_DATA(f.path);
  SourceOptions so;
  so.intrinsics = "fr1";
  auto src = open_frame_source(test::data_path(f.path), so);
  ASSERT_TRUE(src) << src.error().message;
  auto frame = (*src)->frame(f.index);
  ASSERT_TRUE(frame) << frame.error().message;
  FrameReductionOptions o;
  o.params = reduction_preset(Preset::kRealtime);
  o.glb = draco_options();
  o.budget_kb = 40;
  auto t = reduce_and_texture(*frame, o);
  ASSERT_TRUE(t) << t.error().message;
  ASSERT_TRUE(t->geometry_cache) << "a Draco budget keeps its results";
  const GlbWriteOptions cached = write_options(*t, o.glb);
  ASSERT_EQ(cached.draco.cache, t->geometry_cache);
  const size_t hits_before = cached.draco.cache->hits();
  const Scene scene = frame_scene(std::move(*t), "{}");
  auto with_cache = encode_glb(scene, cached);
  auto without = encode_glb(scene, o.glb);
  ASSERT_TRUE(with_cache && without);
  EXPECT_EQ(cached.draco.cache->hits(), hits_before + 1) << "the written mesh is the one the budget measured";
  EXPECT_EQ(*with_cache, *without);
}

TEST(GltfDraco, CoarserPositionStepGivesFewerBytesAndLargerError) {
  const SharedFrame& f = kFrames[0];
  REQUIRE_DATA(f.path);
  const Scene scene = realtime_scene(f.path, f.index);
  GlbWriteOptions fine = draco_options(), coarse = draco_options();
  coarse.position_quantum_m = 0.004;
  GlbStats sf, sc;
  auto a = encode_glb(scene, fine, &sf);
  auto b = encode_glb(scene, coarse, &sc);
  ASSERT_TRUE(a && b);
  EXPECT_LT(sc.geometry_bytes, sf.geometry_bytes);
  auto back = decode_glb(b->data(), b->size());
  ASSERT_TRUE(back);
  const Mesh& m = scene.nodes[0].mesh;
  const auto strict = match_vertices(m, back->nodes[0].mesh, 0.0005, 1.0);
  const auto loose = match_vertices(m, back->nodes[0].mesh, 0.002 + 1e-6, 1.0);
  EXPECT_GT(std::count(strict.begin(), strict.end(), -1L), 0) << "a 4 mm step should move some vertex > 0.5 mm";
  EXPECT_EQ(std::count(loose.begin(), loose.end(), -1L), 0) << "no vertex may move more than half of 4 mm";
}

// ---- hostile input ----

struct DracoGlb {
  json doc;
  std::vector<std::uint8_t> bin;
  size_t draco_off = 0, draco_len = 0;
  std::vector<std::uint8_t> pack() const { return glb::pack_glb(doc.dump(), bin); }
};

DracoGlb real_draco_glb() {
  DracoGlb g;
  auto glb = encode_glb(realtime_scene(kFrames[0].path, kFrames[0].index), draco_options());
  EXPECT_TRUE(glb);
  if (!glb) return g;
  auto chunks = glb::parse_glb(glb->data(), glb->size());
  g.doc = json::parse(chunks->json);
  g.bin = chunks->bin;
  const size_t v = g.doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"];
  g.draco_off = g.doc["bufferViews"][v].value("byteOffset", size_t(0));
  g.draco_len = g.doc["bufferViews"][v]["byteLength"];
  return g;
}

// Draco's varint (draco_header.h) at d[at], its length in *len.
std::uint32_t varint_at(const std::vector<std::uint8_t>& d, size_t at, size_t* len) {
  std::uint32_t v = 0;
  *len = 0;
  while (true) {
    const std::uint8_t b = d[at + *len];
    v |= std::uint32_t(b & 0x7f) << (7 * *len);
    ++*len;
    if (!(b & 0x80)) return v;
  }
}
void append_varint(std::vector<std::uint8_t>* d, std::uint32_t v) {
  do {
    d->push_back(static_cast<std::uint8_t>((v & 0x7f) | (v > 0x7f ? 0x80 : 0)));
    v >>= 7;
  } while (v);
}
// The file with other Draco bytes (the Draco bufferView is the last one in the BIN chunk, as draco_compress writes).
DracoGlb with_draco_bytes(const DracoGlb& g, const std::vector<std::uint8_t>& bytes) {
  DracoGlb h = g;
  h.bin.resize(g.draco_off);
  h.bin.insert(h.bin.end(), bytes.begin(), bytes.end());
  while (h.bin.size() % 4) h.bin.push_back(0);
  const size_t v = h.doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"];
  h.doc["bufferViews"][v]["byteLength"] = bytes.size();
  h.doc["buffers"][0]["byteLength"] = h.bin.size();
  h.draco_len = bytes.size();
  return h;
}

Result<Scene> decode_measured(const std::vector<std::uint8_t>& glb, size_t* peak_bytes, GlbDecodeLimits limits = {}) {
  const size_t base = g_in_use.load();
  g_peak = base;
  auto r = decode_glb(glb.data(), glb.size(), limits);
  *peak_bytes = g_peak.load() - base;
  return r;
}

void expect_refused(const Result<Scene>& r, const std::string& what, const std::string& message_part) {
  ASSERT_FALSE(r.ok()) << what << " was accepted";
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput) << what;
  EXPECT_NE(r.error().message.find(message_part), std::string::npos) << what << ": " << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
}

TEST(GltfDraco, HeaderCountsAreReadWithoutDraco) {
  REQUIRE_DATA(kFrames[0].path);
  const DracoGlb g = real_draco_glb();
  auto h = glb::read_draco_header(g.bin.data() + g.draco_off, g.draco_len);
  ASSERT_TRUE(h) << h.error().message;
  EXPECT_TRUE(h->edgebreaker);
  const json& acc = g.doc["accessors"];
  const auto& prim = g.doc["meshes"][0]["primitives"][0];
  EXPECT_EQ(h->num_faces, acc[prim["indices"].get<size_t>()]["count"].get<size_t>() / 3);
  EXPECT_LE(h->num_vertices, 3 * h->num_faces);
  EXPECT_GT(h->num_vertices, 0u);
  EXPECT_FALSE(glb::read_draco_header(g.bin.data() + g.draco_off, 12));  // cut short
  std::vector<std::uint8_t> meta(g.bin.begin() + g.draco_off, g.bin.begin() + g.draco_off + g.draco_len);
  meta[10] |= 0x80;
  EXPECT_FALSE(glb::read_draco_header(meta.data(), meta.size()));  // metadata flag
}

TEST(GltfDraco, HostileCountsAreRefusedBeforeDracoAllocates) {
  REQUIRE_DATA(kFrames[0].path);
  const DracoGlb g = real_draco_glb();
  const auto& prim = g.doc["meshes"][0]["primitives"][0];
  const size_t pos = prim["attributes"]["POSITION"], uv = prim["attributes"]["TEXCOORD_0"], ind = prim["indices"];
  size_t peak = 0;
  {  // the honest file decodes; its peak is the reference
    auto r = decode_measured(g.pack(), &peak);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_LT(peak, size_t(32) << 20);
  }
  {  // accessors declare more triangles than the Draco data holds
    DracoGlb h = g;
    h.doc["accessors"][ind]["count"] = h.doc["accessors"][ind]["count"].get<size_t>() + 3;
    expect_refused(decode_measured(h.pack(), &peak), "face count mismatch", "faces");
    EXPECT_LT(peak, size_t(4) << 20);
  }
  {  // a billion points and triangles declared: over the limits, before decoding
    DracoGlb h = g;
    h.doc["accessors"][pos]["count"] = 1'000'000'000;
    h.doc["accessors"][uv]["count"] = 1'000'000'000;
    h.doc["accessors"][ind]["count"] = 3'000'000'000ull;
    expect_refused(decode_measured(h.pack(), &peak), "a billion declared", "limit");
    EXPECT_LT(peak, size_t(4) << 20);
  }
  {  // the Draco header says 200M faces (the accessors say 10k): refused before Draco sizes its tables from it
    std::vector<std::uint8_t> d(g.bin.begin() + g.draco_off, g.bin.begin() + g.draco_off + g.draco_len);
    size_t vlen = 0, flen = 0;
    const std::uint32_t vertices = varint_at(d, 12, &vlen);
    varint_at(d, 12 + vlen, &flen);
    std::vector<std::uint8_t> forged(d.begin(), d.begin() + 12);
    append_varint(&forged, vertices);
    append_varint(&forged, 200'000'000);
    forged.insert(forged.end(), d.begin() + 12 + vlen + flen, d.end());
    expect_refused(decode_measured(with_draco_bytes(g, forged).pack(), &peak), "forged face count", "faces");
    EXPECT_LT(peak, size_t(4) << 20);
  }
  {  // the header's vertex count far above 3 x faces (the edgebreaker tables are sized from it)
    std::vector<std::uint8_t> d(g.bin.begin() + g.draco_off, g.bin.begin() + g.draco_off + g.draco_len);
    size_t vlen = 0;
    varint_at(d, 12, &vlen);
    std::vector<std::uint8_t> forged(d.begin(), d.begin() + 12);
    append_varint(&forged, 0xfffffff0u);
    forged.insert(forged.end(), d.begin() + 12 + vlen, d.end());
    expect_refused(decode_measured(with_draco_bytes(g, forged).pack(), &peak), "vertex count over 3 x faces",
                   "vertices");
    EXPECT_LT(peak, size_t(4) << 20);
  }
  {  // a tight limit on the decoded bytes
    GlbDecodeLimits tight;
    tight.max_draco_bytes = 1000;
    expect_refused(decode_measured(g.pack(), &peak, tight), "over max_draco_bytes", "limit");
  }
  {  // an attribute the extension does not name / an unknown Draco id
    DracoGlb h = g;
    h.doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"]["TEXCOORD_0"] = 7;
    expect_refused(decode_measured(h.pack(), &peak), "unknown attribute id", "Draco attribute 7");
  }
  {  // the Draco bufferView past the BIN chunk
    DracoGlb h = g;
    const size_t v = prim["extensions"]["KHR_draco_mesh_compression"]["bufferView"];
    h.doc["bufferViews"][v]["byteLength"] = g.bin.size() + 16;
    auto r = decode_measured(h.pack(), &peak);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  }
}

TEST(GltfDraco, CorruptDracoBytesNeverCrashAndAnAcceptedSceneIsConsistent) {
  REQUIRE_DATA(kFrames[0].path);
  const DracoGlb g = real_draco_glb();
  std::mt19937 rng(7);
  int refused = 0, accepted = 0;
  size_t worst_peak = 0;
  for (int trial = 0; trial < 300; ++trial) {
    DracoGlb h = g;
    const int flips = 1 + trial % 8;
    for (int k = 0; k < flips; ++k) {
      const size_t at = g.draco_off + rng() % std::min<size_t>(g.draco_len, trial < 150 ? 64 : g.draco_len);
      h.bin[at] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
    }
    if (trial % 10 == 9) h.bin.resize(g.draco_off + rng() % g.draco_len);  // truncated
    size_t peak = 0;
    auto r = decode_measured(h.pack(), &peak);
    worst_peak = std::max(worst_peak, peak);
    if (!r.ok()) {
      ++refused;
      EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput) << r.error().message;
      continue;
    }
    ++accepted;
    for (const auto& n : r->nodes)
      for (auto i : n.mesh.indices) ASSERT_LT(i, n.mesh.positions.size());
  }
  EXPECT_GT(refused, 100);
  // Memory stays within a small multiple of the honest decode's (the accessors bound every count).
  EXPECT_LT(worst_peak, size_t(64) << 20);
  std::printf("corrupt Draco data: %d refused, %d accepted, worst peak %.1f MB\n", refused, accepted, worst_peak / 1e6);
}

}  // namespace
