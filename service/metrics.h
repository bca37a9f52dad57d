#pragma once
// Prometheus text exposition (format 0.0.4) of the service's counters: requests by method, route and status,
// request latency histogram by route, render time histogram by mode and backend, rejected renders, and gauges read
// at scrape time (scenes stored, bytes stored, render queue depth, missions stored, event streams open). Routes are
// the API's patterns, never raw paths, so a client cannot grow the label set. Names follow Prometheus' conventions
// (base units: seconds and bytes as the suffix; counters end in _total; latencies are histograms), which
// `promtool check metrics` enforces in tests/service/test_missions.cpp. Thread-safe.
#include <array>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

namespace rgbdcast::service {

struct MetricsGauges {
  size_t scenes_stored = 0;
  std::uint64_t bytes_stored = 0;
  size_t render_queue_depth = 0;
  size_t render_rejected = 0;
  size_t missions_stored = 0;
  size_t event_streams_open = 0;
  size_t resident_part_bytes = 0, resident_parts = 0;  // missions' parts on the renderers (service/render_pool.h)
  // Missions' tiles (service/mission_tiles.h): built by this replica, and hierarchies it loaded as committed.
  std::uint64_t leaves_built = 0, inner_built = 0, hierarchies_loaded = 0;
};

class Histogram {
 public:
  explicit Histogram(std::vector<double> upper_bounds) : bounds_(std::move(upper_bounds)), counts_(bounds_.size(), 0) {}
  void observe(double v);
  // Appends the _bucket/_sum/_count lines; labels is "" or `a="b",c="d"`.
  void write(std::string& out, const std::string& name, const std::string& labels) const;

 private:
  std::vector<double> bounds_;
  std::vector<std::uint64_t> counts_;  // per bucket, not cumulative
  std::uint64_t count_ = 0;
  double sum_ = 0.0;
};

class Metrics {
 public:
  void observe_request(const std::string& method, const std::string& route, int status, double seconds);
  void observe_render(const std::string& mode, const std::string& backend, double render_seconds);
  std::string prometheus_text(const MetricsGauges& gauges) const;

 private:
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, std::uint64_t> requests_;
  std::map<std::string, Histogram> latency_;                         // by route
  std::map<std::pair<std::string, std::string>, Histogram> render_;  // by mode, backend
};

// Escapes a label value for the text format (backslash, quote, newline).
std::string escape_label(const std::string& value);

}  // namespace rgbdcast::service
