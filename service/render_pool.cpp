#include "service/render_pool.h"

#include <malloc.h>

#include <chrono>
#include <list>
#include <utility>

namespace rgbdcast::service {
namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

struct RenderPool::Worker {
  struct Resident {
    std::string scene_id;
    ResidentSceneId device_id;
    std::vector<CaptureCamera> cameras;
    std::set<std::string> node_names;  // what append() skips
  };
  std::thread thread;
  std::unique_ptr<Renderer> renderer;
  std::list<Resident> resident;       // most recently used first
  std::vector<std::string> forgotten;  // guarded by the pool's mutex
  std::vector<std::shared_ptr<Append>> appends;  // guarded by the pool's mutex
  bool rendered_large = false;         // since the renderer was made
  bool heap_dirty = false;             // rendered since the last malloc_trim
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
  job->queued_at = std::chrono::steady_clock::now();
  auto future = job->promise.get_future();
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return make_error(ErrorCode::kUnavailable, "server is stopping");
    // Admitted when a worker is idle or the queue has room: waiting + rendering < workers + capacity.
    if (queue_.size() + busy_ >= workers_.size() + static_cast<size_t>(options_.queue_capacity)) {
      ++rejected_;
      return make_error(ErrorCode::kUnavailable, "render queue full (" + std::to_string(queue_.size()) +
                                                     " views waiting); retry later");
    }
    queue_.push_back(std::move(job));
  }
  cv_.notify_one();
  return future.get();
}

void RenderPool::forget(const std::string& scene_id) {
  std::lock_guard lock(mutex_);
  for (auto& w : workers_) w->forgotten.push_back(scene_id);
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
    if (it->node_names.count(node.name)) all_fresh = false;
    else fresh.nodes.push_back(node);
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

void RenderPool::release_when_idle(Worker* w, const RendererFactory& factory) {
  if (w->rendered_large) {
    Result<std::unique_ptr<Renderer>> fresh = make_error(ErrorCode::kInternal, "renderer factory threw");
    try {
      fresh = factory();
    } catch (const std::exception&) {
    }
    if (fresh) {  // else the old renderer stays: a view is better served with extra memory than not at all
      for (auto& r : w->resident) w->renderer->release(r.device_id);
      w->resident.clear();
      w->renderer = std::move(*fresh);
      w->rendered_large = false;
      std::lock_guard lock(mutex_);
      ++resets_;
    }
  }
  if (w->heap_dirty) {
    ::malloc_trim(0);
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
      if (!cv_.wait_for(lock, idle, [&] { return stopping_ || !queue_.empty() || !w->appends.empty(); })) {
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
    auto work = [&]() -> Result<RenderOutput> {
      auto it = w->resident.begin();
      while (it != w->resident.end() && it->scene_id != job->scene_id) ++it;
      if (it == w->resident.end()) {
        const auto t0 = std::chrono::steady_clock::now();
        auto scene = loader_(job->scene_id);
        if (!scene) return scene.error();
        out.load_ms = ms_since(t0);
        auto id = w->renderer->upload(**scene, &out.upload_ms);
        if (!id) return id.error();
        std::set<std::string> names;
        for (const SceneNode& node : (*scene)->nodes) names.insert(node.name);
        w->resident.push_front({job->scene_id, *id, (*scene)->cameras, std::move(names)});
        while (w->resident.size() > static_cast<size_t>(options_.resident_scenes)) {
          w->renderer->release(w->resident.back().device_id);
          w->resident.pop_back();
        }
      } else {
        w->resident.splice(w->resident.begin(), w->resident, it);
      }
      const Worker::Resident& r = w->resident.front();
      auto camera = make_view_camera(job->request, r.cameras);
      if (!camera) return camera.error();
      RenderOptions options;
      options.mode = job->request.mode;
      options.point_size_px = job->request.point_size_px;
      auto rendered = w->renderer->render(r.device_id, *camera, options);
      if (!rendered) return rendered.error();
      w->heap_dirty = true;
      if (static_cast<long long>(job->request.width) * job->request.height > options_.large_view_px)
        w->rendered_large = true;
      out.color = std::move(rendered->color);
      out.render_ms = rendered->timings.render_ms;
      out.readback_ms = rendered->timings.readback_ms;
      return std::move(out);
    };
    Result<RenderOutput> result = make_error(ErrorCode::kInternal, "render failed");
    try {
      result = work();
    } catch (const std::exception& e) {
      result = make_error(ErrorCode::kInternal, std::string("render threw: ") + e.what());
    }
    {
      std::lock_guard lock(mutex_);
      --busy_;
    }
    job->promise.set_value(std::move(result));
  }
  for (auto& r : w->resident) w->renderer->release(r.device_id);
  w->resident.clear();
  w->renderer.reset();
}

}  // namespace rgbdcast::service
