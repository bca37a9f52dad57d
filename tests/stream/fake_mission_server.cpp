#include "tests/stream/fake_mission_server.h"

#include <chrono>
#include <cstdlib>
#include <sstream>

#include <nlohmann/json.hpp>

#include "base/stopwatch.h"
#include "tests/common/test_data.h"

namespace rgbdcast::test {
namespace {

// "tx,ty,tz,qx,qy,qz,qw" as the sender writes it (stream::pose_query); false when it is not seven numbers.
bool parse_pose(const std::string& text, std::array<double, 7>& pose) {
  std::istringstream in(text);
  std::string part;
  size_t n = 0;
  while (std::getline(in, part, ',')) {
    if (n == pose.size()) return false;
    char* end = nullptr;
    pose[n++] = std::strtod(part.c_str(), &end);
    if (end == part.c_str() || *end != '\0') return false;
  }
  return n == pose.size();
}

void send(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(body.dump(), "application/json");
}

}  // namespace

FakeMissionServer::FakeMissionServer() : FakeMissionServer(Script{}) {}

FakeMissionServer::FakeMissionServer(Script script) : script_(std::move(script)) {
  dir_ = temp_dir("fake_mission_server");
  auto store = service::MissionStore::open(dir_);
  if (store) store_ = std::move(*store);
  server_.Post(R"(/v1/missions/([A-Za-z0-9_-]+)/keyframes)",
               [this](const httplib::Request& req, httplib::Response& res) { post_keyframe(req, res); });
  server_.Get(R"(/v1/missions/([A-Za-z0-9_-]+))", [this](const httplib::Request& req, httplib::Response& res) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& k : keyframes(req.matches[1])) list.push_back(k.entry());
    send(res, 200, {{"keyframes", list}});
  });
}

FakeMissionServer::~FakeMissionServer() {
  stop();
  store_.reset();
  remove_tree_quietly(dir_);
}

int FakeMissionServer::start(int port) {
  if (!store_) return -1;
  if (port == 0) {
    port_ = server_.bind_to_any_port("127.0.0.1");
  } else {
    port_ = server_.bind_to_port("127.0.0.1", port) ? port : -1;
  }
  if (port_ < 0) return -1;
  thread_ = std::thread([this] { server_.listen_after_bind(); });
  return port_;
}

void FakeMissionServer::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  changed_.notify_all();
  server_.stop();
  if (thread_.joinable()) thread_.join();
}

std::string FakeMissionServer::url() const { return "http://127.0.0.1:" + std::to_string(port_); }

bool FakeMissionServer::wait_until(const std::function<bool(const std::vector<ServedPost>&)>& done, double timeout_s) {
  std::unique_lock lock(mu_);
  changed_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return stopping_ || done(posts_); });
  const bool met = done(posts_);
  if (!met && !stopping_) ++held_too_long_;
  return met;
}

std::vector<ServedPost> FakeMissionServer::posts() const {
  std::lock_guard lock(mu_);
  return posts_;
}

int FakeMissionServer::held_too_long() const {
  std::lock_guard lock(mu_);
  return held_too_long_;
}

std::vector<service::MissionKeyframe> FakeMissionServer::keyframes(const std::string& mission) const {
  auto k = store_->keyframes(mission);
  return k ? *k : std::vector<service::MissionKeyframe>{};
}

void FakeMissionServer::post_keyframe(const httplib::Request& req, httplib::Response& res) {
  ServedPost post;
  post.seq = std::atoi(req.get_param_value("seq").c_str());
  post.rev = req.has_param("rev") ? std::atoi(req.get_param_value("rev").c_str()) : 0;
  post.bytes = req.body.size();
  size_t index = 0;
  auto decide = [&](int status) {
    std::lock_guard lock(mu_);
    posts_[index].status = status;
  };
  auto answer = [&](int status, const nlohmann::json& body) {
    {
      std::lock_guard lock(mu_);
      posts_[index].status = status;
      posts_[index].answer_step = ++step_;
      if (status >= 400) posts_[index].error = body.value("error", "");
    }
    changed_.notify_all();
    send(res, status, body);
  };
  int scripted = 0;
  {
    std::lock_guard lock(mu_);
    post.body_step = ++step_;
    post.body_unix_s = unix_seconds_now();
    if (script_.refuse_token) {
      scripted = 401;
    } else if (script_.fail_with_503 > 0) {
      --script_.fail_with_503;
      scripted = 503;
    }
    posts_.push_back(post);
    index = posts_.size() - 1;
  }
  changed_.notify_all();
  if (scripted == 401) return answer(401, {{"error", "unauthorized"}, {"message", "bad token"}});
  if (scripted == 503) {
    res.set_header("Retry-After", "1");
    return answer(503, {{"error", "busy"}});
  }
  if (script_.hold) script_.hold(*this, post);

  service::MissionKeyframe k;
  k.mission = req.matches[1];
  k.seq = post.seq;
  k.rev = post.rev;
  k.captured = req.has_param("captured") ? std::atof(req.get_param_value("captured").c_str()) : 0;
  k.received = unix_seconds_now();
  if (!parse_pose(req.get_param_value("pose"), k.pose)) return answer(400, {{"error", "bad pose"}});
  auto put = store_->put(k, std::vector<std::uint8_t>(req.body.begin(), req.body.end()));
  if (!put) return answer(500, {{"error", put.error().message}});
  switch (put->outcome) {
    case service::PutOutcome::kSame:
      return answer(200, put->keyframe.answer());
    case service::PutOutcome::kConflict:
      return answer(409, {{"error", "conflict"}, {"stored", put->keyframe.answer()}});
    case service::PutOutcome::kStale:
      return answer(409, {{"error", "stale_revision"}, {"stored", put->keyframe.answer()}});
    case service::PutOutcome::kCreated:
    case service::PutOutcome::kReplaced:
      break;
  }
  (void)store_->mark_available(k.mission, k.seq, unix_seconds_now());
  decide(201);
  bool swallow = false;
  {
    std::lock_guard lock(mu_);
    if (script_.swallow > 0) {
      --script_.swallow;
      swallow = true;
    }
  }
  if (swallow)  // until the client gave up and posted the same revision again
    wait_until([&](const std::vector<ServedPost>& posts) {
      for (size_t i = index + 1; i < posts.size(); ++i)
        if (posts[i].seq == post.seq && posts[i].rev == post.rev) return true;
      return false;
    });
  answer(201, put->keyframe.answer());
}

}  // namespace rgbdcast::test
