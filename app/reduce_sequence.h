#pragma once
// rgbdcast reduce --sequence: track the sequence, reduce and texture each keyframe, place it in the first frame's
// world, write one multi-view GLB and the report with a `frames` entry per frame.
#include "app/reduce_common.h"
#include "input/frame_source.h"

namespace rgbdcast::app {

Status run_sequence(const ReduceArgs& args, const FrameSource& source);

}  // namespace rgbdcast::app
