-- wrk script for bench/load.sh: GET views of one scene from a ring of viewpoints around its centre (so every request
-- renders a different image), then print p50/p99 latency, views/s and errors in a form load.sh reads.
-- Arguments (after --): scene_ids cx cy cz radius width height; scene_ids is one id or several joined by commas
-- (scenes of the same frame: one orbit serves all; bench/cluster_load.sh spreads views over replicas that way).
local scene, cx, cy, cz, radius, width, height
local paths = {}
local counter = 0

function init(args)
  scene = args[1]
  cx, cy, cz = tonumber(args[2]), tonumber(args[3]), tonumber(args[4])
  radius = tonumber(args[5])
  width, height = args[6] or "640", args[7] or "480"
  -- 36 viewpoints, 10 degrees apart, on a horizontal ring through the capture side (world up is -y).
  for i = 0, 35 do
    local a = math.rad(i * 10 - 180)
    local ex, ez = cx + radius * math.sin(a), cz - radius * math.cos(a)
    for id in string.gmatch(scene, "[^,]+") do
      paths[#paths + 1] = string.format(
        "/v1/scenes/%s/view?eye=%.4f,%.4f,%.4f&target=%.4f,%.4f,%.4f&up=0,-1,0&fov=55&width=%s&height=%s&format=jpeg&quality=85",
        id, ex, cy, ez, cx, cy, cz, width, height)
    end
  end
  counter = math.random(0, #paths - 1)
end

function request()
  counter = counter + 1
  return wrk.format("GET", paths[(counter % #paths) + 1])
end

function done(summary, latency, requests)
  local e = summary.errors
  local errors = e.connect + e.read + e.write + e.status + e.timeout
  local seconds = summary.duration / 1e6
  io.write(string.format("RESULT requests=%d seconds=%.2f views_per_s=%.2f p50_ms=%.2f p90_ms=%.2f p99_ms=%.2f max_ms=%.2f errors=%d status_errors=%d timeouts=%d\n",
    summary.requests, seconds, summary.requests / seconds, latency:percentile(50) / 1000,
    latency:percentile(90) / 1000, latency:percentile(99) / 1000, latency.max / 1000, errors, e.status, e.timeout))
end
