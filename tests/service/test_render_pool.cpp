// The render pool with a stand-in renderer (the real backends are tested in tests/renderer): the bounded queue
// refuses work at once when full, resident scenes are reused and forgotten, errors pass through.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include "service/render_pool.h"

using namespace rgbdcast;
using namespace rgbdcast::service;

namespace {

struct Counters {
  std::atomic<int> uploads{0}, releases{0}, renders{0}, loads{0}, appended_nodes{0};
  std::atomic<int> render_sleep_ms{0};
  std::atomic<int> last_ids{0};           // resident scenes the last render drew together
  std::atomic<int> live{0}, max_live{0};  // uploaded and not released: now, and at most since the last reset
  // Batched views: renders that kept the previous targets, and renders that read the image back.
  std::atomic<int> kept_targets{0}, read_backs{0};
  // A closed gate holds every render until it opens (a GPU busy for as long as the test needs).
  std::mutex gate_mu;
  std::condition_variable gate_cv;
  bool gate_closed = false;
  void open_gate() {
    {
      std::lock_guard lock(gate_mu);
      gate_closed = false;
    }
    gate_cv.notify_all();
  }
};

// Fills the image with a colour derived from the resident id; sleeps to simulate a slow GPU.
class StandInRenderer : public Renderer {
 public:
  explicit StandInRenderer(Counters* c) : c_(c) {}
  std::string backend() const override { return "standin"; }
  std::string device() const override { return "test"; }
  Result<ResidentSceneId> upload(const Scene& scene, double* upload_ms) override {
    if (scene.nodes.empty()) return make_error(ErrorCode::kEmpty, "empty scene");
    ++c_->uploads;
    c_->max_live = std::max(c_->max_live.load(), ++c_->live);
    if (upload_ms) *upload_ms = 1.0;
    return ++next_;
  }
  Status append(ResidentSceneId, const Scene& scene, double*) override {
    if (scene.nodes.empty()) return make_error(ErrorCode::kEmpty, "empty part");
    if (scene.nodes[0].name == "bad") return make_error(ErrorCode::kInvalidInput, "bad part");
    c_->appended_nodes += static_cast<int>(scene.nodes.size());
    return ok_status();
  }
  void release(ResidentSceneId) override {
    ++c_->releases;
    --c_->live;
  }
  Result<RenderResult> render_scenes(std::span<const ResidentSceneId> ids, const ViewCamera& cam,
                                     const RenderOptions& options) override {
    ++c_->renders;
    c_->kept_targets += options.keep_targets;
    c_->read_backs += options.read_back;
    const ResidentSceneId id = ids.empty() ? 0 : ids.back();
    c_->last_ids = static_cast<int>(ids.size());
    {
      std::unique_lock lock(c_->gate_mu);
      c_->gate_cv.wait(lock, [this] { return !c_->gate_closed; });
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(c_->render_sleep_ms.load()));
    RenderResult r;
    r.color = Image::make(cam.width, cam.height, 4);
    for (size_t i = 0; i < r.color.data.size(); ++i) r.color.data[i] = static_cast<std::uint8_t>(id * 40);
    r.timings.render_ms = 2.0;
    return r;
  }

 private:
  Counters* c_;
  ResidentSceneId next_ = 0;
};

std::unique_ptr<RenderPool> make_pool(Counters* c, RenderPoolOptions o) {
  auto pool = RenderPool::start(
      o, [c]() -> Result<std::unique_ptr<Renderer>> { return std::unique_ptr<Renderer>(new StandInRenderer(c)); },
      [c](const std::string& id) -> Result<std::shared_ptr<const Scene>> {
        ++c->loads;
        if (id == "missing") return make_error(ErrorCode::kNotFound, "no scene missing");
        auto s = std::make_shared<Scene>();
        if (id != "empty") s->nodes.resize(1);
        return std::shared_ptr<const Scene>(s);
      });
  EXPECT_TRUE(pool.ok());
  return pool.ok() ? std::move(*pool) : nullptr;
}

ViewRequest capture(int w = 64, int h = 48) {
  ViewRequest r;
  r.width = w;
  r.height = h;
  return r;
}

}  // namespace

TEST(ServiceRenderPool, RendersAndKeepsScenesResident) {
  Counters c;
  auto pool = make_pool(&c, {1, 4, 2});
  ASSERT_TRUE(pool);
  EXPECT_EQ(pool->backend(), "standin");
  for (int i = 0; i < 3; ++i) {
    auto out = pool->render("a", capture());
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_EQ(out->color.width, 64);
    EXPECT_EQ(out->backend, "standin");
    EXPECT_EQ(out->upload_ms > 0, i == 0);  // only the first view uploads
  }
  EXPECT_EQ(c.uploads, 1);
  EXPECT_EQ(c.loads, 1);
  // Two more scenes with room for two: "a" is the least recently used and goes.
  ASSERT_TRUE(pool->render("b", capture()).ok());
  ASSERT_TRUE(pool->render("c", capture()).ok());
  EXPECT_EQ(c.releases, 1);
  ASSERT_TRUE(pool->render("a", capture()).ok());
  EXPECT_EQ(c.uploads, 4);
  // A forgotten (deleted) scene is released before the next job and loaded again if asked.
  pool->forget("a");
  ASSERT_TRUE(pool->render("c", capture()).ok());
  EXPECT_EQ(c.releases, 3);
}

// A resident scene grows in place (a live mission): every worker that holds it appends the part's new nodes, nodes
// it already has are skipped, a worker without it appends nothing, and a failed append drops the scene so that the
// next view loads it whole.
TEST(ServiceRenderPool, AppendGrowsResidentScenesOnEveryWorker) {
  Counters c;
  auto pool = make_pool(&c, {2, 4, 2});
  ASSERT_TRUE(pool);
  // Two views at once so that both workers hold "m".
  c.render_sleep_ms = 200;
  std::thread other([&] { EXPECT_TRUE(pool->render("m", capture()).ok()); });
  ASSERT_TRUE(pool->render("m", capture()).ok());
  other.join();
  c.render_sleep_ms = 0;
  ASSERT_EQ(c.loads, 2);
  auto part = [](std::vector<std::string> names) {
    auto s = std::make_shared<Scene>();
    for (auto& n : names) {
      SceneNode node;
      node.name = n;
      s->nodes.push_back(node);
    }
    s->cameras.resize(1);
    return std::shared_ptr<const Scene>(s);
  };
  ASSERT_TRUE(pool->append("m", part({"keyframe_1"})));
  EXPECT_EQ(c.appended_nodes, 2);  // one node on each of the two workers
  ASSERT_TRUE(pool->append("m", part({"keyframe_1", "keyframe_2"})));
  EXPECT_EQ(c.appended_nodes, 4);  // keyframe_1 skipped, keyframe_2 appended on both
  ASSERT_TRUE(pool->append("elsewhere", part({"keyframe_1"})));
  EXPECT_EQ(c.appended_nodes, 4);  // nobody holds it
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(pool->render("m", capture()).ok());
  EXPECT_EQ(c.loads, 2) << "a view after an append loaded the scene again";
  auto failed = pool->append("m", part({"bad"}));
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().code, ErrorCode::kInvalidInput);
  ASSERT_TRUE(pool->render("m", capture()).ok());
  EXPECT_EQ(c.loads, 3);  // dropped, then loaded whole
}

TEST(ServiceRenderPool, ErrorsPassThrough) {
  Counters c;
  auto pool = make_pool(&c, {1, 4, 2});
  ASSERT_TRUE(pool);
  auto missing = pool->render("missing", capture());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  auto empty = pool->render("empty", capture());
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().code, ErrorCode::kEmpty);
  ViewRequest bad = capture();
  bad.capture_pose = false;
  bad.eye = {0, 0, 0};
  bad.target = {0, -1, 0};  // parallel to the default up
  auto r = pool->render("a", bad);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
}

// One worker busy (its render held until the test lets it go), a queue of 2: of 8 requests, 1 renders, 2 wait, and
// the other 5 are refused with kUnavailable while the render is still held: at once, not after waiting for it.
TEST(ServiceRenderPool, FullQueueRefusesAtOnce) {
  Counters c;
  auto pool = make_pool(&c, {1, 2, 2});
  ASSERT_TRUE(pool);
  ASSERT_TRUE(pool->render("a", capture()).ok());  // warm: the scene is resident
  {
    std::lock_guard lock(c.gate_mu);
    c.gate_closed = true;
  }
  std::atomic<int> ok{0}, refused{0};
  auto client = [&] {
    auto r = pool->render("a", capture());
    if (r.ok()) {
      ++ok;
    } else {
      EXPECT_EQ(r.error().code, ErrorCode::kUnavailable);
      EXPECT_NE(r.error().message.find("queue full"), std::string::npos);
      ++refused;
    }
  };
  auto wait_for = [](const std::function<bool()>& done) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!done() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    return done();
  };
  std::vector<std::thread> clients;
  auto give_up = [&] {  // (a failed wait: the threads are let go before the test ends)
    c.open_gate();
    for (auto& t : clients) t.join();
  };
  clients.emplace_back(client);  // the first one starts rendering, and is held
  if (!wait_for([&] { return c.renders == 2; })) {
    ADD_FAILURE() << "the render never started";
    return give_up();
  }
  for (int i = 0; i < 2; ++i) clients.emplace_back(client);  // two wait in the queue
  if (!wait_for([&] { return pool->queue_depth() == 2; })) {
    ADD_FAILURE() << "the queue never held two";
    return give_up();
  }
  for (int i = 0; i < 5; ++i) clients.emplace_back(client);
  wait_for([&] { return refused == 5; });  // answered while the render is still held (a refusal that waited never is)
  EXPECT_EQ(refused, 5);
  EXPECT_EQ(ok, 0);
  c.open_gate();
  for (auto& t : clients) t.join();
  EXPECT_EQ(ok, 3);
  EXPECT_EQ(refused, 5);
  EXPECT_EQ(pool->rejected(), 5u);
}

// No waiting room at all: an idle worker still takes a view; a second one at the same time is refused.
TEST(ServiceRenderPool, ZeroQueueStillUsesIdleWorkers) {
  Counters c;
  c.render_sleep_ms = 200;
  auto pool = make_pool(&c, {1, 0, 2});
  ASSERT_TRUE(pool);
  ASSERT_TRUE(pool->render("a", capture()).ok());
  Result<RenderOutput> second = make_error(ErrorCode::kInternal, "not run");
  std::thread first([&] { EXPECT_TRUE(pool->render("a", capture()).ok()); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  second = pool->render("a", capture());
  first.join();
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.error().code, ErrorCode::kUnavailable);
  EXPECT_TRUE(pool->render("a", capture()).ok());  // idle again
}

TEST(ServiceRenderPool, FactoryFailureIsAnError) {
  auto pool = RenderPool::start(
      {2, 4, 2}, []() -> Result<std::unique_ptr<Renderer>> { return make_error(ErrorCode::kUnavailable, "no GPU"); },
      [](const std::string&) -> Result<std::shared_ptr<const Scene>> { return make_error(ErrorCode::kNotFound, "x"); });
  ASSERT_FALSE(pool.ok());
  EXPECT_EQ(pool.error().code, ErrorCode::kUnavailable);
  EXPECT_EQ(pool.error().message, "no GPU");
}

namespace rgbdcast::service {
namespace {

// A part whose mesh costs `kilobytes` * 1000 device bytes (24-byte vertices), loaded by counting.
ViewPart sized_part(const std::string& key, int kilobytes, Counters* c) {
  return {key, [kilobytes, c]() -> Result<std::shared_ptr<const Scene>> {
            ++c->loads;
            auto s = std::make_shared<Scene>();
            s->nodes.resize(1);
            s->nodes[0].mesh.positions.resize(static_cast<size_t>(kilobytes) * 1000 / 24);
            return std::shared_ptr<const Scene>(s);
          }};
}

std::vector<ViewPart> parts(const std::string& prefix, int first, int count, Counters* c) {
  std::vector<ViewPart> out;
  for (int i = first; i < first + count; ++i) out.push_back(sized_part(prefix + std::to_string(i), 240, c));
  return out;
}

}  // namespace

// Parts (a tiled mission's tiles) stay resident least-recently-used under a byte cap: a view loads only the parts it
// lacks, the cap holds after every view whose own parts fit, a view whose parts exceed it still draws them all, and
// forget() drops a mission's parts.
TEST(ServiceRenderPool, PartsStayResidentUnderTheByteCap) {
  Counters c;
  RenderPoolOptions o{1, 4, 2};
  o.resident_part_bytes = 1000 * 1000;  // four 240 kB parts
  auto pool = make_pool(&c, o);
  ASSERT_TRUE(pool);
  ViewCamera camera;
  camera.width = 32;
  camera.height = 24;
  auto first = pool->render_parts(parts("m/t", 0, 3, &c), camera, capture());
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_EQ(first->parts_drawn, 3u);
  EXPECT_EQ(first->parts_loaded, 3u);
  EXPECT_EQ(c.last_ids, 3);
  auto again = pool->render_parts(parts("m/t", 0, 3, &c), camera, capture());
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->parts_loaded, 0u) << "resident parts were loaded again";
  EXPECT_EQ(c.loads, 3);
  // A camera that moves along: each view adds one part, and the oldest go once the cap is reached.
  for (int i = 1; i < 10; ++i) {
    auto v = pool->render_parts(parts("m/t", i, 3, &c), camera, capture());
    ASSERT_TRUE(v.ok());
    EXPECT_EQ(v->parts_loaded, 1u) << i;
    EXPECT_LE(pool->resident_part_bytes(), o.resident_part_bytes) << i;
    EXPECT_EQ(pool->resident_part_bytes(), pool->resident_parts() * 240000u) << i;
  }
  // Ten parts at once are over the cap: all drawn, in batches that each fit it, the first clearing the image and
  // each later one drawn over it, the image read back once; never more than the cap's four parts resident.
  EXPECT_EQ(first->batches, 1u);
  c.max_live = c.live.load();
  const int renders_before = c.renders, kept_before = c.kept_targets, read_before = c.read_backs;
  auto wide = pool->render_parts(parts("m/w", 0, 10, &c), camera, capture());
  ASSERT_TRUE(wide.ok());
  EXPECT_EQ(wide->parts_drawn, 10u);
  EXPECT_EQ(wide->parts_loaded, 10u);
  EXPECT_EQ(wide->batches, 3u);  // 4 + 4 + 2
  EXPECT_EQ(c.renders - renders_before, 3);
  EXPECT_EQ(c.kept_targets - kept_before, 2);
  EXPECT_EQ(c.read_backs - read_before, 1);
  EXPECT_EQ(c.last_ids, 2);
  EXPECT_EQ(wide->color.width, camera.width);
  EXPECT_LE(c.max_live, 4);
  EXPECT_LE(pool->resident_part_bytes(), o.resident_part_bytes);
  EXPECT_GT(pool->resident_parts(), 0u);
  // A part that is gone (a retired tile file) is left out; the rest is drawn.
  std::vector<ViewPart> with_gone = parts("m/w", 0, 2, &c);
  with_gone.push_back({"m/gone", []() -> Result<std::shared_ptr<const Scene>> {
                         return make_error(ErrorCode::kNotFound, "no tile file");
                       }});
  auto partial = pool->render_parts(std::move(with_gone), camera, capture());
  ASSERT_TRUE(partial.ok());
  EXPECT_EQ(partial->parts_drawn, 2u);
  EXPECT_EQ(partial->parts_missing, 1u);
  // Any other load error fails the view.
  std::vector<ViewPart> broken = {{"m/broken", []() -> Result<std::shared_ptr<const Scene>> {
                                     return make_error(ErrorCode::kInternal, "does not decode");
                                   }}};
  auto failed = pool->render_parts(std::move(broken), camera, capture());
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().code, ErrorCode::kInternal);
  // forget("m") drops every part under "m/" before the next job.
  pool->forget("m");
  ASSERT_TRUE(pool->render_parts({}, camera, capture()).ok());
  EXPECT_EQ(pool->resident_parts(), 0u);
  EXPECT_EQ(pool->resident_part_bytes(), 0u);
}

}  // namespace rgbdcast::service
