#pragma once
// A fixed set of renderers, each owned by one worker thread (a Renderer is used by one thread at a time, and an
// OSMesa context belongs to the thread that made it), fed by one bounded queue. Contract:
// - render() blocks until the view is rendered, or fails at once with kUnavailable "render queue full" when every
//   worker is busy and `queue_capacity` jobs are already waiting (the HTTP layer answers 503 with Retry-After): load
//   sheds instead of piling up.
// - Each worker keeps up to `resident_scenes` scenes uploaded (least recently used goes first); forget() drops a
//   deleted scene from every worker at once (a busy worker after its current job).
// - Scenes are loaded through the SceneLoader (decoded GLB) on a cache miss; a loader error is returned as is.
// - render_parts() draws a view from parts that are resident one by one: a tiled mission's selected tiles and the
//   keyframes its tileset does not hold yet. A part's key names its content for ever (an immutable tile file, a
//   keyframe revision), so a resident part is never stale. Each worker keeps its parts in a least-recently-used set
//   capped at resident_part_bytes / workers (estimated device bytes: vertices, indices, RGBA8 textures), checked
//   as each part loads. A view whose own parts exceed the cap still draws them all, in batches that each fit it
//   (drawn over one another, colour and depth kept), so the set never holds more than the cap plus one part (such
//   views load their parts again each time: the cap is too small for them).
//   Renderers do not share device memory (each backend instance has its own device), so the cap is the total over
//   the workers, not per worker. forget(key) drops the parts whose key starts with key + "/".
// - append() grows a resident scene in place (a live mission gains a keyframe): each worker that holds the scene
//   uploads only the new nodes (Renderer::append); a worker that does not hold it loads it whole on its next view.
#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "renderer/renderer.h"
#include "scene/result.h"
#include "scene/scene.h"
#include "service/view_params.h"

namespace rgbdcast::service {

struct RenderPoolOptions {
  int workers = 1;          // renderer instances (lavapipe and llvmpipe already use every core for one frame)
  int queue_capacity = 32;  // jobs waiting beyond those being rendered
  int resident_scenes = 8;  // per worker
  // Memory: a worker that rendered a view larger than large_view_px and then sat idle for idle_release_s drops its
  // renderer (and with it the render targets it caches by size) for a fresh one, and every idle worker returns
  // freed heap to the system (malloc_trim): after a burst of large views RSS goes back near its base.
  double idle_release_s = 5.0;
  int large_view_px = 1920 * 1080;
  size_t resident_part_bytes = size_t(512) << 20;  // render_parts(): all workers' resident parts together
};

// A part of a view: its key (unique and immutable, see above) and how to load it on a miss.
struct ViewPart {
  std::string key;
  std::function<Result<std::shared_ptr<const Scene>>()> load;
};

struct RenderOutput {
  Image color;             // RGBA8
  double render_ms = 0.0;  // renderer: submission to idle
  double readback_ms = 0.0;
  double upload_ms = 0.0;  // > 0 only when this request uploaded the scene
  double load_ms = 0.0;    // GLB decode on a cache miss
  double queue_ms = 0.0;   // waiting for a worker
  std::string backend;
  // render_parts(): parts drawn, loaded by this view (misses), and left out because they no longer load (kNotFound:
  // a tile file retired meanwhile).
  size_t parts_drawn = 0, parts_loaded = 0, parts_missing = 0;
  // render_parts(): the batches the parts were drawn in (more than one when they did not fit the cap together).
  size_t batches = 0;
};

using RendererFactory = std::function<Result<std::unique_ptr<Renderer>>()>;
using SceneLoader = std::function<Result<std::shared_ptr<const Scene>>(const std::string& scene_id)>;

class RenderPool {
 public:
  // Starts the workers; each creates its renderer in its own thread. Fails when the first renderer cannot be made.
  static Result<std::unique_ptr<RenderPool>> start(const RenderPoolOptions& options, RendererFactory factory,
                                                   SceneLoader loader);
  ~RenderPool();
  RenderPool(const RenderPool&) = delete;
  RenderPool& operator=(const RenderPool&) = delete;

  Result<RenderOutput> render(const std::string& scene_id, const ViewRequest& request);
  // The parts drawn together from `camera` (request gives the mode, point size and image format). Queued and shed
  // like render().
  Result<RenderOutput> render_parts(std::vector<ViewPart> parts, const ViewCamera& camera, const ViewRequest& request);
  void forget(const std::string& scene_id);
  // Adds `part`'s nodes and cameras to `scene_id` on every worker that has it resident, and returns once every worker
  // has done so (a worker busy with a view finishes that view first; nothing waits in the render queue). Nodes whose
  // name the resident scene already has are skipped: a worker that loaded the scene after the part was stored has it.
  // A worker whose append fails drops the scene (its next view loads it whole); the first such error is returned.
  // kUnavailable when the pool is stopping.
  Status append(const std::string& scene_id, std::shared_ptr<const Scene> part);

  const std::string& backend() const { return backend_; }
  const std::string& device() const { return device_; }
  size_t queue_depth() const;
  size_t rejected() const;
  size_t renderer_resets() const;      // renderers replaced after idle (see idle_release_s)
  size_t resident_part_bytes() const;  // over all workers, as the cap counts them
  size_t part_cap_bytes() const;       // one worker's share of the cap: the most one view keeps resident
  size_t resident_parts() const;

 private:
  struct Job {
    std::string scene_id;
    ViewRequest request;
    std::optional<std::vector<ViewPart>> parts;  // render_parts()
    ViewCamera camera;                           // render_parts()
    std::chrono::steady_clock::time_point queued_at;
    std::promise<Result<RenderOutput>> promise;
  };
  struct Worker;
  struct Append {
    std::string scene_id;
    std::shared_ptr<const Scene> part;
    size_t remaining = 0;  // workers that have not applied it yet (guarded by mutex_)
    std::optional<Error> error;
  };
  void apply_append(Worker* worker, Append& append);
  Result<RenderOutput> submit(std::unique_ptr<Job> job);
  Result<RenderOutput> render_scene_job(Worker* worker, Job& job, RenderOutput out);
  Result<RenderOutput> render_parts_job(Worker* worker, Job& job, RenderOutput out);
  void drop_parts(Worker* worker, const std::string& prefix);
  // Releases least recently used parts until the worker's are within `cap` bytes, keeping the `keep` most recent.
  void evict_parts(Worker* worker, size_t cap, size_t keep);
  void release_all(Worker* worker);

  explicit RenderPool(const RenderPoolOptions& options, SceneLoader loader);
  void run(Worker* worker, RendererFactory factory, std::promise<Status> started);
  void release_when_idle(Worker* worker, const RendererFactory& factory);

  RenderPoolOptions options_;
  SceneLoader loader_;
  std::string backend_, device_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::condition_variable appended_cv_;
  std::deque<std::unique_ptr<Job>> queue_;
  bool stopping_ = false;
  size_t rejected_ = 0;
  size_t resets_ = 0;
  size_t busy_ = 0;  // jobs being rendered
  std::vector<std::unique_ptr<Worker>> workers_;
};

}  // namespace rgbdcast::service
