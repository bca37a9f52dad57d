#pragma once
// The sender's HTTP side: posts keyframes to the missions routes (see the contract in README, "Live missions") with
// cpp-httplib's client over one keep-alive connection, and reads a mission back. Each answer is classified for the
// sender's retry logic. httplib stays inside uplink.cpp. Not thread-safe: one sender thread owns it.
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "scene/result.h"
#include "stream/outbox.h"

namespace rgbdcast::stream {

struct UplinkOptions {
  std::string server_url;  // http://host:port (or https://), no path
  std::string token;       // bearer token; empty: none
  double connect_timeout_s = 2;
};

enum class PostOutcome {
  kStored,    // 201, or 200 (an identical re-post: the server already had it)
  kRetry,     // no answer (connection, timeout), 5xx, 503/429 (retry_after_s may be set)
  kConflict,  // 409: the server holds this (mission, seq, rev) with other bytes or another pose, or a newer rev
  kRejected,  // any other 4xx: retrying the same bytes cannot succeed
  kFatal,     // 401/403: the token is wrong; the sender stops
};

struct PostResult {
  PostOutcome outcome = PostOutcome::kRetry;
  int status = 0;     // HTTP status; 0 when no answer
  std::string body;   // the server's JSON
  std::string error;  // one line: why (status and error field, or the connection error)
  double retry_after_s = -1;
  double seconds = 0;  // from the request's start to its answer
};

// A body written in chunks (Uplink::post_keyframe): called before each chunk of at most kBodyChunkBytes, from the
// posting thread; it may wait (the sender paces a refinement's body at the cap and lets a new keyframe's body go
// ahead of the rest of it) and returns false to abort the POST (then the outcome is kRetry).
using ChunkGate = std::function<bool(size_t offset, size_t bytes)>;
inline constexpr size_t kBodyChunkBytes = 4096;

class Uplink {
 public:
  // Errors: kInvalidArgument (a URL that is not http(s)://host[:port]).
  static Result<std::unique_ptr<Uplink>> create(const UplinkOptions& options);
  ~Uplink();

  // GET /healthz: kUnavailable with the connection error when the server cannot be reached.
  Status check_reachable();
  // The seconds a GET /healthz takes on this uplink's connection (open it first, e.g. with check_reachable, so that no
  // TCP handshake is in it): a request's round trip without a body, the POST model's first fixed cost. kUnavailable
  // without an answer.
  Result<double> round_trip_s();
  // POST /v1/missions/{mission}/keyframes?seq=&pose=&captured=[&rev=, when entry.rev > 0]; io_timeout_s bounds each
  // socket write and the wait for the answer. With a gate, the body is written chunk by chunk through it (above);
  // without, in one piece.
  PostResult post_keyframe(const std::string& mission, const OutboxEntry& entry, const std::vector<std::uint8_t>& glb,
                           double io_timeout_s, const ChunkGate& gate = {});
  // GET /v1/missions/{mission}: the JSON text; kNotFound for an unknown mission, kUnavailable without an answer.
  Result<std::string> get_mission(const std::string& mission);

 private:
  struct Impl;
  explicit Uplink(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Reads a bearer token file as `rgbdcast serve` does: the whole file, whitespace trimmed, one token. Errors name the
// file: kNotFound (unreadable), kInvalidInput (empty, or characters that cannot go in an HTTP header).
Result<std::string> read_token_file(const std::string& path);

}  // namespace rgbdcast::stream
