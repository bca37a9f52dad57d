#pragma once
// The mission server of the sender's tests: the keyframe routes of `rgbdcast serve` (POST
// /v1/missions/{name}/keyframes, GET /v1/missions/{name}) over the real service::MissionStore in a temporary folder,
// so that idempotency (200 for the same bytes), conflicts and stale revisions (409) are the service's own, with
// scripted failures and answers held back that a test needs to put the sender in a given situation.
//
// Order, not time: every POST is recorded with the step at which its body was read and the step at which its answer
// was decided (one counter for the whole server), so that a test asserts what came before what. A test holds an
// answer back until something has happened (another body has come, the same keyframe was posted again) with
// `hold`, and the server records a hold that gave up (held_too_long) rather than answering late in silence. No
// GLB is decoded: the sender does not look inside its bodies, and the tests post parts of real files.
// Thread-safety: every method may be called from any thread; `hold` runs on the server's threads, unlocked.
#include <httplib.h>

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "service/mission_store.h"

namespace rgbdcast::test {

struct ServedPost {
  int seq = -1, rev = 0;
  size_t bytes = 0;
  int status = 0;          // the answer's status, once decided (also when the client no longer waits for it)
  long body_step = 0;      // when its body had been read
  long answer_step = -1;   // when its answer was sent (-1: not yet)
  std::string error;       // of a 4xx/5xx answer: its "error" ("stale_revision", "conflict", "busy", ...)
  double body_unix_s = 0;  // when its body had been read (for lower bounds only: pacing never lets it come sooner)
};

class FakeMissionServer {
 public:
  struct Script {
    int fail_with_503 = 0;      // the first POSTs get 503 with Retry-After: 1, nothing stored
    int swallow = 0;            // then the answers of this many stored keyframes are held until the same (seq, rev) is
                                // posted again (the client gave up on it): the keyframe is stored, its answer lost
    bool refuse_token = false;  // every POST gets 401 (a wrong token)
    // Called once a POST's body was read, before it is stored (the service's time: what another POST stores
    // meanwhile decides this one's answer, e.g. 409 stale_revision), without the server's lock; may wait with
    // wait_until() or sleep. `post` is the request as recorded so far.
    std::function<void(FakeMissionServer&, const ServedPost& post)> hold;
  };

  FakeMissionServer();
  explicit FakeMissionServer(Script script);
  ~FakeMissionServer();  // stops the server and removes its folder
  FakeMissionServer(const FakeMissionServer&) = delete;
  FakeMissionServer& operator=(const FakeMissionServer&) = delete;

  // Listens on 127.0.0.1:port (0: any free port) on a thread of its own; returns the port, or -1.
  int start(int port = 0);
  void stop();
  std::string url() const;

  // Waits at most timeout_s until `done(posts)` holds; false when it never did (held_too_long() counts it) or the
  // server is stopping.
  bool wait_until(const std::function<bool(const std::vector<ServedPost>&)>& done, double timeout_s = 20);
  std::vector<ServedPost> posts() const;
  int held_too_long() const;
  service::MissionStore& store() { return *store_; }
  // The keyframes of `mission` as stored (by seq; empty for an unknown mission).
  std::vector<service::MissionKeyframe> keyframes(const std::string& mission) const;

 private:
  void post_keyframe(const httplib::Request& req, httplib::Response& res);

  Script script_;
  std::string dir_;
  std::unique_ptr<service::MissionStore> store_;
  httplib::Server server_;
  std::thread thread_;
  int port_ = -1;
  mutable std::mutex mu_;
  std::condition_variable changed_;
  std::vector<ServedPost> posts_;
  long step_ = 0;
  int held_too_long_ = 0;
  bool stopping_ = false;
};

}  // namespace rgbdcast::test
