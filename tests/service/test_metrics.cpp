// Prometheus text: counters by label set, cumulative histogram buckets, gauges.
#include <gtest/gtest.h>

#include "service/metrics.h"

using namespace rgbdcast::service;

namespace {
bool has_line(const std::string& text, const std::string& line) {
  return text.find("\n" + line + "\n") != std::string::npos || text.rfind(line + "\n", 0) == 0;
}
}  // namespace

TEST(ServiceMetrics, CountersHistogramsGauges) {
  Metrics m;
  m.observe_request("GET", "/v1/scenes/{id}/view", 200, 0.004);
  m.observe_request("GET", "/v1/scenes/{id}/view", 200, 0.030);
  m.observe_request("GET", "/v1/scenes/{id}/view", 400, 0.0001);
  m.observe_render("mesh", "vulkan", 0.0125);
  m.observe_render("mesh", "vulkan", 0.150);
  MetricsGauges g;
  g.scenes_stored = 3;
  g.bytes_stored = 123456;
  const std::string t = m.prometheus_text(g);
  EXPECT_TRUE(has_line(t, R"(rgbdcast_http_requests_total{method="GET",route="/v1/scenes/{id}/view",status="200"} 2)"))
      << t;
  EXPECT_TRUE(has_line(t, R"(rgbdcast_http_requests_total{method="GET",route="/v1/scenes/{id}/view",status="400"} 1)"));
  // Buckets are cumulative: 0.0001 and 0.004 are <= 0.005, all three <= 0.05.
  EXPECT_TRUE(
      has_line(t, R"(rgbdcast_http_request_duration_seconds_bucket{route="/v1/scenes/{id}/view",le="0.005"} 2)"))
      << t;
  EXPECT_TRUE(
      has_line(t, R"(rgbdcast_http_request_duration_seconds_bucket{route="/v1/scenes/{id}/view",le="+Inf"} 3)"));
  EXPECT_TRUE(has_line(t, R"(rgbdcast_http_request_duration_seconds_count{route="/v1/scenes/{id}/view"} 3)"));
  EXPECT_TRUE(has_line(t, R"(rgbdcast_render_duration_seconds_bucket{mode="mesh",backend="vulkan",le="0.02"} 1)"));
  EXPECT_TRUE(has_line(t, R"(rgbdcast_render_duration_seconds_bucket{mode="mesh",backend="vulkan",le="0.2"} 2)"));
  EXPECT_TRUE(has_line(t, R"(rgbdcast_render_duration_seconds_sum{mode="mesh",backend="vulkan"} 0.1625)"));
  EXPECT_TRUE(has_line(t, "rgbdcast_scenes_stored 3"));
  EXPECT_TRUE(has_line(t, "rgbdcast_scenes_stored_bytes 123456"));
  EXPECT_TRUE(has_line(t, "# TYPE rgbdcast_render_duration_seconds histogram"));
}

TEST(ServiceMetrics, LabelValuesAreEscaped) { EXPECT_EQ(escape_label("a\"b\\c\nd"), "a\\\"b\\\\c\\nd"); }
