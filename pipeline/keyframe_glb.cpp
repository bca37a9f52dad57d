#include "pipeline/keyframe_glb.h"

namespace rgbdcast {

nlohmann::json reduction_choices(const TexturedFrame& f) {
  nlohmann::json j = {{"preset", to_string(f.preset)}, {"texture", to_string(f.atlas_stats.mode)}};
  if (f.budget.budget_bytes > 0) {
    const BudgetChoice& b = f.budget;
    j["budget"] = {{"budget_bytes", b.budget_bytes},
                   {"tolerance_factor", b.tolerance_factor},
                   {"simplify_px", b.simplify_px},
                   {"jpeg_quality", b.jpeg_quality},
                   {"texture_scale", b.texture_scale},
                   {"geometry_bytes", b.geometry_bytes},
                   {"texture_bytes", b.texture_bytes},
                   {"glb_bytes", b.glb_bytes},
                   {"encodes", b.encodes},
                   {"meshes", b.meshes},
                   {"rule", b.rule}};
  }
  return j;
}

Result<std::vector<std::uint8_t>> encode_keyframe_glb(TexturedFrame frame, nlohmann::json capture,
                                                      const GlbWriteOptions& glb, GlbStats* stats) {
  if (!capture.is_object())
    return make_error(ErrorCode::kInvalidArgument, "a keyframe's capture extras must be a JSON object");
  capture["reduction"] = reduction_choices(frame);
  const GlbWriteOptions options = write_options(frame, glb);  // the codec and results the budget measured with
  const nlohmann::json extras = {{"rgbdcast", std::move(capture)}};
  return encode_glb(frame_scene(std::move(frame), extras.dump()), options, stats);
}

}  // namespace rgbdcast
