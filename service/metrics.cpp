#include "service/metrics.h"

#include <cstdio>

namespace rgbdcast::service {
namespace {

const std::vector<double> kLatencyBounds_s = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1,
                                              0.25,  0.5,    1.0,   2.5,  5.0,   10.0};
const std::vector<double> kRenderBounds_s = {0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5};

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.15g", v);
  return buf;
}

}  // namespace

std::string escape_label(const std::string& value) {
  std::string out;
  for (char c : value) {
    if (c == '\\')
      out += "\\\\";
    else if (c == '"')
      out += "\\\"";
    else if (c == '\n')
      out += "\\n";
    else
      out += c;
  }
  return out;
}

void Histogram::observe(double v) {
  size_t i = 0;
  while (i < bounds_.size() && v > bounds_[i]) ++i;
  if (i < bounds_.size()) ++counts_[i];
  ++count_;
  sum_ += v;
}

void Histogram::write(std::string& out, const std::string& name, const std::string& labels) const {
  const std::string sep = labels.empty() ? "" : ",";
  std::uint64_t cumulative = 0;
  for (size_t i = 0; i < bounds_.size(); ++i) {
    cumulative += counts_[i];
    out += name + "_bucket{" + labels + sep + "le=\"" + number(bounds_[i]) + "\"} " + std::to_string(cumulative) + "\n";
  }
  out += name + "_bucket{" + labels + sep + "le=\"+Inf\"} " + std::to_string(count_) + "\n";
  const std::string braces = labels.empty() ? "" : "{" + labels + "}";
  out += name + "_sum" + braces + " " + number(sum_) + "\n";
  out += name + "_count" + braces + " " + std::to_string(count_) + "\n";
}

void Metrics::observe_request(const std::string& method, const std::string& route, int status, double seconds) {
  std::lock_guard lock(mutex_);
  ++requests_[{method, route, status}];
  auto it = latency_.find(route);
  if (it == latency_.end()) it = latency_.emplace(route, Histogram(kLatencyBounds_s)).first;
  it->second.observe(seconds);
}

void Metrics::observe_render(const std::string& mode, const std::string& backend, double render_seconds) {
  std::lock_guard lock(mutex_);
  auto key = std::make_pair(mode, backend);
  auto it = render_.find(key);
  if (it == render_.end()) it = render_.emplace(key, Histogram(kRenderBounds_s)).first;
  it->second.observe(render_seconds);
}

std::string Metrics::prometheus_text(const MetricsGauges& g) const {
  std::string out;
  std::lock_guard lock(mutex_);
  out += "# HELP rgbdcast_http_requests_total HTTP requests by method, route pattern and status.\n";
  out += "# TYPE rgbdcast_http_requests_total counter\n";
  for (const auto& [key, n] : requests_) {
    const auto& [method, route, status] = key;
    out += "rgbdcast_http_requests_total{method=\"" + escape_label(method) + "\",route=\"" + escape_label(route) +
           "\",status=\"" + std::to_string(status) + "\"} " + std::to_string(n) + "\n";
  }
  out += "# HELP rgbdcast_http_request_duration_seconds Time from routing to response, by route pattern.\n";
  out += "# TYPE rgbdcast_http_request_duration_seconds histogram\n";
  for (const auto& [route, h] : latency_)
    h.write(out, "rgbdcast_http_request_duration_seconds", "route=\"" + escape_label(route) + "\"");
  out +=
      "# HELP rgbdcast_render_duration_seconds Renderer time per view (submission to idle, without readback), by "
      "mode and backend.\n";
  out += "# TYPE rgbdcast_render_duration_seconds histogram\n";
  for (const auto& [key, h] : render_)
    h.write(out, "rgbdcast_render_duration_seconds",
            "mode=\"" + escape_label(key.first) + "\",backend=\"" + escape_label(key.second) + "\"");
  out += "# HELP rgbdcast_render_rejected_total Views refused with 503 because the render queue was full.\n";
  out += "# TYPE rgbdcast_render_rejected_total counter\n";
  out += "rgbdcast_render_rejected_total " + std::to_string(g.render_rejected) + "\n";
  out += "# HELP rgbdcast_tiles_built_total Mission tiles this replica built, by kind (leaf: a keyframe's; inner).\n";
  out += "# TYPE rgbdcast_tiles_built_total counter\n";
  out += "rgbdcast_tiles_built_total{kind=\"leaf\"} " + std::to_string(g.leaves_built) + "\n";
  out += "rgbdcast_tiles_built_total{kind=\"inner\"} " + std::to_string(g.inner_built) + "\n";
  out +=
      "# HELP rgbdcast_tile_hierarchies_loaded_total Mission tile hierarchies opened as committed (from the disk or "
      "the database), not built.\n";
  out += "# TYPE rgbdcast_tile_hierarchies_loaded_total counter\n";
  out += "rgbdcast_tile_hierarchies_loaded_total " + std::to_string(g.hierarchies_loaded) + "\n";
  auto gauge = [&out](const char* name, const char* help, const std::string& value) {
    out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " gauge\n" + name + " " + value + "\n";
  };
  gauge("rgbdcast_render_queue_depth", "Views waiting for a renderer.", std::to_string(g.render_queue_depth));
  gauge("rgbdcast_scenes_stored", "Scenes in the store.", std::to_string(g.scenes_stored));
  gauge("rgbdcast_scenes_stored_bytes", "Bytes of GLB in the store.", std::to_string(g.bytes_stored));
  gauge("rgbdcast_missions_stored", "Live missions in the store.", std::to_string(g.missions_stored));
  gauge("rgbdcast_event_streams_open", "Mission event streams open (each holds an HTTP thread).",
        std::to_string(g.event_streams_open));
  gauge(
      "rgbdcast_resident_part_bytes",
      "Estimated device bytes of the mission tiles and keyframes resident on the renderers (capped by --resident-mb).",
      std::to_string(g.resident_part_bytes));
  gauge("rgbdcast_resident_parts", "Mission tiles and keyframes resident on the renderers.",
        std::to_string(g.resident_parts));
  return out;
}

}  // namespace rgbdcast::service
