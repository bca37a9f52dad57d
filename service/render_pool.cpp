#include "service/render_pool.h"

#include <atomic>
#include <chrono>
#include <list>
#include <unordered_map>
#include <utility>

#include "base/malloc_settings.h"
#include "base/stopwatch.h"
#include "scene/render_bytes.h"

namespace rgbdcast::service {
namespace {}  // namespace

struct RenderPool::Worker {
  struct Resident {
    std::string scene_id;
    ResidentSceneId device_id;
    std::vector<CaptureCamera> cameras;
    std::set<std::string> node_names;  // what append() skips
  };
  std::thread thread;
  std::unique_ptr<Renderer> renderer;
  std::list<Resident> resident;  // most recently used first
  struct Part {
    std::string key;
    ResidentSceneId device_id;
    size_t bytes;
  };
  std::list<Part> parts;  // most recently used first
  std::unordered_map<std::string, std::list<Part>::iterator> part_index;
  std::atomic<size_t> part_bytes{0}, part_count{0};  // written by the worker, read by stats
  std::vector<std::string> forgotten;                // guarded by the pool's mutex
  std::vector<std::shared_ptr<Append>> appends;      // guarded by the pool's mutex
  bool rendered_large = false;                       // since the renderer was made
  bool heap_dirty = false;                           // rendered since the last malloc_trim
};

RenderPool::RenderPool(const RenderPoolOptions& options, SceneLoader loader)
    : options_(options), loader_(std::move(loader)) {}

Result<std::unique_ptr<RenderPool>> RenderPool::start(const RenderPoolOptions& options, RendererFactory factory,
                                                      SceneLoader loader) {
  if (options.workers < 1 || options.queue_capacity < 0 || options.resident_scenes < 1)
    return make_error(ErrorCode::kInvalidArgument, "render pool needs at least one worker and one resident scene");
  std::unique_ptr<RenderPool> pool(new RenderPool(options, std::move(loader)));
  for (int i = 0; i < options.workers; ++i) {
    auto worker = std::make_unique<Worker>();
    std::promise<Status> started;
    auto started_future = started.get_future();
    Worker* w = worker.get();
    worker->thread = std::thread(&RenderPool::run, pool.get(), w, factory, std::move(started));
    pool->workers_.push_back(std::move(worker));
    Status st = started_future.get();
    if (!st) return st.error();  // the destructor joins the threads already started
    if (i == 0) {
      pool->backend_ = w->renderer->backend();
      pool->device_ = w->renderer->device();
    }
  }
  return pool;
}

RenderPool::~RenderPool() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (auto& w : workers_)
    if (w->thread.joinable()) w->thread.join();
  appended_cv_.notify_all();
  for (auto& job : queue_) job->promise.set_value(make_error(ErrorCode::kUnavailable, "server is stopping"));
}

Result<RenderOutput> RenderPool::render(const std::string& scene_id, const ViewRequest& request) {
  auto job = std::make_unique<Job>();
  job->scene_id = scene_id;
  job->request = request;
  return submit(std::move(job));
}

Result<RenderOutput> RenderPool::render_parts(std::vector<ViewPart> parts, const ViewCamera& camera,
                                              const ViewRequest& request) {
  auto job = std::make_unique<Job>();
  job->parts = std::move(parts);
  job->camera = camera;
  job->request = request;
  return submit(std::move(job));
}

Result<RenderOutput> RenderPool::submit(std::unique_ptr<Job> job) {
  job->queued_at = std::chrono::steady_clock::now();
  auto future = job->promise.get_future();
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return make_error(ErrorCode::kUnavailable, "server is stopping");
    // Admitted when a worker is idle or the queue has room: waiting + rendering < workers + capacity.
    if (queue_.size() + busy_ >= workers_.size() + static_cast<size_t>(options_.queue_capacity)) {
      ++rejected_;
      return make_error(ErrorCode::kUnavailable,
                        "render queue full (" + std::to_string(queue_.size()) + " views waiting); retry later");
    }
    queue_.push_back(std::move(job));
  }
  cv_.notify_one();
  return future.get();
}

void RenderPool::forget(const std::string& scene_id) {
  {
    std::lock_guard lock(mutex_);
    for (auto& w : workers_) w->forgotten.push_back(scene_id);
  }
  cv_.notify_all();  // idle workers release at once (a deleted mission's parts leave the device)
}

Status RenderPool::append(const std::string& scene_id, std::shared_ptr<const Scene> part) {
  auto task = std::make_shared<Append>();
  task->scene_id = scene_id;
  task->part = std::move(part);
  std::unique_lock lock(mutex_);
  if (stopping_) return make_error(ErrorCode::kUnavailable, "server is stopping");
  task->remaining = workers_.size();
  for (auto& w : workers_) w->appends.push_back(task);
  cv_.notify_all();
  appended_cv_.wait(lock, [&] { return stopping_ || task->remaining == 0; });
  if (task->remaining > 0) return make_error(ErrorCode::kUnavailable, "server is stopping");
  if (task->error) return *task->error;
  return ok_status();
}

void RenderPool::apply_append(Worker* w, Append& task) {
  auto it = w->resident.begin();
  while (it != w->resident.end() && it->scene_id != task.scene_id) ++it;
  if (it == w->resident.end()) return;
  Scene fresh;  // the part without the nodes this resident scene already has
  bool all_fresh = true;
  for (const SceneNode& node : task.part->nodes) {
    if (it->node_names.count(node.name))
      all_fresh = false;
    else
      fresh.nodes.push_back(node);
  }
  if (fresh.nodes.empty()) return;
  Status st = make_error(ErrorCode::kInternal, "append threw");
  try {
    st = w->renderer->append(it->device_id, all_fresh ? *task.part : fresh);
  } catch (const std::exception& e) {
    st = make_error(ErrorCode::kInternal, std::string("append threw: ") + e.what());
  }
  if (!st) {
    w->renderer->release(it->device_id);
    w->resident.erase(it);
    std::lock_guard lock(mutex_);
    if (!task.error && st.error().code != ErrorCode::kUnavailable) task.error = st.error();
    return;
  }
  for (const SceneNode& node : task.part->nodes) it->node_names.insert(node.name);
  it->cameras.insert(it->cameras.end(), task.part->cameras.begin(), task.part->cameras.end());
  w->heap_dirty = true;
}

size_t RenderPool::queue_depth() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

size_t RenderPool::rejected() const {
  std::lock_guard lock(mutex_);
  return rejected_;
}

size_t RenderPool::renderer_resets() const {
  std::lock_guard lock(mutex_);
  return resets_;
}

size_t RenderPool::part_cap_bytes() const { return options_.resident_part_bytes / workers_.size(); }

size_t RenderPool::resident_part_bytes() const {
  size_t bytes = 0;
  for (const auto& w : workers_) bytes += w->part_bytes.load();
  return bytes;
}

size_t RenderPool::resident_parts() const {
  size_t n = 0;
  for (const auto& w : workers_) n += w->part_count.load();
  return n;
}

void RenderPool::drop_parts(Worker* w, const std::string& prefix) {
  for (auto it = w->parts.begin(); it != w->parts.end();) {
    if (it->key.rfind(prefix, 0) == 0) {
      w->renderer->release(it->device_id);
      w->part_bytes -= it->bytes;
      w->part_index.erase(it->key);
      it = w->parts.erase(it);
    } else {
      ++it;
    }
  }
  w->part_count = w->parts.size();
}

void RenderPool::evict_parts(Worker* w, size_t cap, size_t keep) {
  while (w->part_bytes > cap && w->parts.size() > keep) {
    const Worker::Part& old = w->parts.back();
    w->renderer->release(old.device_id);
    w->part_bytes -= old.bytes;
    w->part_index.erase(old.key);
    w->parts.pop_back();
  }
  w->part_count = w->parts.size();
}

void RenderPool::release_all(Worker* w) {
  for (auto& r : w->resident) w->renderer->release(r.device_id);
  w->resident.clear();
  drop_parts(w, "");
}

void RenderPool::release_when_idle(Worker* w, const RendererFactory& factory) {
  if (w->rendered_large) {
    Result<std::unique_ptr<Renderer>> fresh = make_error(ErrorCode::kInternal, "renderer factory threw");
    try {
      fresh = factory();
    } catch (const std::exception&) {}
    if (fresh) {  // else the old renderer stays: a view is better served with extra memory than not at all
      release_all(w);
      w->renderer = std::move(*fresh);
      w->rendered_large = false;
      std::lock_guard lock(mutex_);
      ++resets_;
    }
  }
  if (w->heap_dirty) {
    return_freed_heap();
    w->heap_dirty = false;
  }
}

void RenderPool::run(Worker* w, RendererFactory factory, std::promise<Status> started) {
  {
    Result<std::unique_ptr<Renderer>> made = make_error(ErrorCode::kInternal, "renderer factory threw");
    try {
      made = factory();
    } catch (const std::exception& e) {
      made = make_error(ErrorCode::kInternal, std::string("renderer factory threw: ") + e.what());
    }
    if (!made) {
      started.set_value(made.error());
      return;
    }
    w->renderer = std::move(*made);
    started.set_value(ok_status());
  }
  for (;;) {
    std::unique_ptr<Job> job;
    std::vector<std::string> forgotten;
    std::vector<std::shared_ptr<Append>> appends;
    {
      std::unique_lock lock(mutex_);
      const auto idle = std::chrono::duration<double>(options_.idle_release_s);
      if (!cv_.wait_for(lock, idle,
                        [&] { return stopping_ || !queue_.empty() || !w->appends.empty() || !w->forgotten.empty(); })) {
        lock.unlock();
        release_when_idle(w, factory);
        continue;
      }
      if (stopping_) break;
      forgotten.swap(w->forgotten);
      appends.swap(w->appends);
      if (!queue_.empty()) {
        job = std::move(queue_.front());
        queue_.pop_front();
        ++busy_;
      }
    }
    for (const auto& id : forgotten) {
      for (auto it = w->resident.begin(); it != w->resident.end();) {
        if (it->scene_id == id) {
          w->renderer->release(it->device_id);
          it = w->resident.erase(it);
        } else {
          ++it;
        }
      }
      drop_parts(w, id + "/");
    }
    if (!appends.empty()) {
      for (const auto& task : appends) apply_append(w, *task);
      {
        std::lock_guard lock(mutex_);
        for (const auto& task : appends) --task->remaining;
      }
      appended_cv_.notify_all();
    }
    if (!job) continue;
    RenderOutput out;
    out.queue_ms = ms_since(job->queued_at);
    out.backend = w->renderer->backend();
    Result<RenderOutput> result = make_error(ErrorCode::kInternal, "render failed");
    try {
      result = job->parts ? render_parts_job(w, *job, std::move(out)) : render_scene_job(w, *job, std::move(out));
    } catch (const std::exception& e) {
      result = make_error(ErrorCode::kInternal, std::string("render threw: ") + e.what());
    }
    {
      std::lock_guard lock(mutex_);
      --busy_;
    }
    job->promise.set_value(std::move(result));
  }
  release_all(w);
  w->renderer.reset();
}

Result<RenderOutput> RenderPool::render_scene_job(Worker* w, Job& job, RenderOutput out) {
  auto it = w->resident.begin();
  while (it != w->resident.end() && it->scene_id != job.scene_id) ++it;
  if (it == w->resident.end()) {
    const auto t0 = std::chrono::steady_clock::now();
    auto scene = loader_(job.scene_id);
    if (!scene) return scene.error();
    out.load_ms = ms_since(t0);
    auto id = w->renderer->upload(**scene, &out.upload_ms);
    if (!id) return id.error();
    std::set<std::string> names;
    for (const SceneNode& node : (*scene)->nodes) names.insert(node.name);
    w->resident.push_front({job.scene_id, *id, (*scene)->cameras, std::move(names)});
    while (w->resident.size() > static_cast<size_t>(options_.resident_scenes)) {
      w->renderer->release(w->resident.back().device_id);
      w->resident.pop_back();
    }
  } else {
    w->resident.splice(w->resident.begin(), w->resident, it);
  }
  const Worker::Resident& r = w->resident.front();
  auto camera = make_view_camera(job.request, r.cameras);
  if (!camera) return camera.error();
  RenderOptions options;
  options.mode = job.request.mode;
  options.point_size_px = job.request.point_size_px;
  auto rendered = w->renderer->render(r.device_id, *camera, options);
  if (!rendered) return rendered.error();
  w->heap_dirty = true;
  if (static_cast<long long>(job.request.width) * job.request.height > options_.large_view_px) w->rendered_large = true;
  out.color = std::move(rendered->color);
  out.render_ms = rendered->timings.render_ms;
  out.readback_ms = rendered->timings.readback_ms;
  return out;
}

Result<RenderOutput> RenderPool::render_parts_job(Worker* w, Job& job, RenderOutput out) {
  const size_t cap = part_cap_bytes();
  RenderOptions options;
  options.mode = job.request.mode;
  options.point_size_px = job.request.point_size_px;
  // The parts are drawn in batches that fit the worker's share of the cap: a batch is drawn over the previous one
  // (colour and depth kept), after which its parts may be evicted to make room for the next. A view whose parts fit
  // is one batch, as before; one whose parts do not (a full-detail overview of a long mission) keeps the device, and
  // the process, within the cap instead of holding every part at once.
  std::vector<ResidentSceneId> batch;
  size_t batch_bytes = 0;
  auto draw_batch = [&](bool last) -> Status {
    options.read_back = last;
    auto rendered = w->renderer->render_scenes(batch, job.camera, options);
    if (!rendered) return rendered.error();
    out.render_ms += rendered->timings.render_ms;
    out.readback_ms += rendered->timings.readback_ms;
    if (last) out.color = std::move(rendered->color);
    options.keep_targets = true;
    ++out.batches;
    out.parts_drawn += batch.size();
    batch.clear();
    batch_bytes = 0;
    return ok_status();
  };
  for (const ViewPart& part : *job.parts) {
    auto found = w->part_index.find(part.key);
    if (found != w->part_index.end()) {
      if (!batch.empty() && batch_bytes + found->second->bytes > cap)
        if (Status s = draw_batch(false); !s) return s.error();
      w->parts.splice(w->parts.begin(), w->parts, found->second);
    } else {
      const auto t0 = std::chrono::steady_clock::now();
      auto scene = part.load();
      out.load_ms += ms_since(t0);
      if (!scene && scene.error().code == ErrorCode::kNotFound) {
        ++out.parts_missing;
        continue;
      }
      if (!scene) return scene.error();
      const size_t bytes = render_bytes(**scene);
      if (!batch.empty() && batch_bytes + bytes > cap)
        if (Status s = draw_batch(false); !s) return s.error();
      // Room for the part, keeping the batch being gathered.
      evict_parts(w, cap > bytes ? cap - bytes : 0, batch.size());
      double upload_ms = 0.0;
      auto id = w->renderer->upload(**scene, &upload_ms);
      if (!id && id.error().code == ErrorCode::kEmpty) continue;
      if (!id) return id.error();
      out.upload_ms += upload_ms;
      ++out.parts_loaded;
      w->parts.push_front({part.key, *id, bytes});
      w->part_index[part.key] = w->parts.begin();
      w->part_bytes += bytes;
      w->part_count = w->parts.size();
    }
    batch.push_back(w->parts.front().device_id);
    batch_bytes += w->parts.front().bytes;
  }
  Status drawn = draw_batch(true);
  evict_parts(w, cap, 0);
  if (!drawn) return drawn.error();
  w->heap_dirty = true;
  if (static_cast<long long>(job.camera.width) * job.camera.height > options_.large_view_px) w->rendered_large = true;
  return out;
}

}  // namespace rgbdcast::service
