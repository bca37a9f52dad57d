#pragma once
// The `frames` array of `rgbdcast reduce --sequence --report`: one entry per frame {index, timestamp, matches,
// inliers, keyframe, tracked, method, reference, pose, icp, ms, track_ms, message}, method how the pose was found
// ("first", "window", "wide", "relocalised"; "none" when skipped), reference the frame it was estimated against,
// pose the camera-to-world 4x4 as row-major nested lists (null when the frame was skipped), in the first tracked
// frame's coordinates.
#include <nlohmann/json.hpp>

#include "keyframes/pose_error.h"
#include "keyframes/sequence.h"

namespace rgbdcast {

nlohmann::json frame_record_json(const FrameRecord& record);
nlohmann::json frames_json(const SequenceResult& result);
// {pairs: [{from, to, translation_m, rotation_deg}], translation_rmse_m, ..., warnings}
nlohmann::json rpe_json(const RpeResult& rpe);

}  // namespace rgbdcast
