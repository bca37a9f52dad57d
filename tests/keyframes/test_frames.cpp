#include "tests/keyframes/test_frames.h"

#include "tests/common/test_data.h"

namespace rgbdcast::test {

FrameLoader TestSequence::loader() const {
  std::shared_ptr<FrameSource> s = source;
  std::string why = error;
  return [s, why](size_t i) -> Result<RgbdFrame> {
    if (!s) return make_error(ErrorCode::kNotFound, why);
    return s->frame(i);
  };
}

TestSequence open_test_sequence(const std::string& name, const std::string& data_relative) {
  TestSequence t;
  t.name = name;
  Result<std::unique_ptr<FrameSource>> s = open_frame_source(data_path(data_relative), SourceOptions{});
  if (s)
    t.source = std::shared_ptr<FrameSource>(std::move(*s));
  else
    t.error = s.error().message;
  return t;
}

TestSequence augmented_icl_sequence() {
  return open_test_sequence("augmented_icl_livingroom", "augmented_icl_livingroom");
}
TestSequence icl_nuim_sequence() { return open_test_sequence("icl_nuim_livingroom", "icl_nuim_livingroom"); }
TestSequence tum_fr1_xyz_sequence() { return open_test_sequence("tum_fr1_xyz", "tum/rgbd_dataset_freiburg1_xyz"); }

}  // namespace rgbdcast::test
