#include "keyframes/sequence_report.h"

namespace rgbdcast {

nlohmann::json frame_record_json(const FrameRecord& r) {
  nlohmann::json j;
  j["index"] = r.index;
  j["timestamp"] = r.timestamp;
  j["matches"] = r.matches;
  j["inliers"] = r.inliers;
  j["keyframe"] = r.keyframe;
  j["tracked"] = r.tracked;
  j["method"] = to_string(r.method);
  j["reference"] = r.reference;
  if (r.tracked) {
    nlohmann::json rows = nlohmann::json::array();
    for (int i = 0; i < 4; ++i) rows.push_back({r.pose(i, 0), r.pose(i, 1), r.pose(i, 2), r.pose(i, 3)});
    j["pose"] = rows;
  } else {
    j["pose"] = nullptr;
  }
  j["icp"] = r.icp_used;
  j["ms"] = r.ms;
  j["track_ms"] = r.track_ms;
  if (!r.message.empty()) j["message"] = r.message;
  return j;
}

nlohmann::json frames_json(const SequenceResult& result) {
  nlohmann::json a = nlohmann::json::array();
  for (const FrameRecord& r : result.frames) a.push_back(frame_record_json(r));
  return a;
}

nlohmann::json rpe_json(const RpeResult& rpe) {
  nlohmann::json j;
  nlohmann::json pairs = nlohmann::json::array();
  for (const RpePair& p : rpe.pairs)
    pairs.push_back({{"from", p.from_index},
                     {"to", p.to_index},
                     {"translation_m", p.translation_m},
                     {"rotation_deg", p.rotation_deg},
                     {"gt_translation_m", p.gt_translation_m},
                     {"gt_rotation_deg", p.gt_rotation_deg}});
  j["pairs"] = pairs;
  j["translation_rmse_m"] = rpe.translation_rmse_m;
  j["translation_mean_m"] = rpe.translation_mean_m;
  j["translation_max_m"] = rpe.translation_max_m;
  j["rotation_rmse_deg"] = rpe.rotation_rmse_deg;
  j["rotation_mean_deg"] = rpe.rotation_mean_deg;
  j["rotation_max_deg"] = rpe.rotation_max_deg;
  j["warnings"] = rpe.warnings;
  return j;
}

}  // namespace rgbdcast
