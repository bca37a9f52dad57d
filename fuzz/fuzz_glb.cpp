// libFuzzer: decode_glb on arbitrary bytes (the body of POST /v1/scenes). Any input must give a Scene or a one-line
// kInvalidInput/kEmpty error, within the default limits; ASan/UBSan abort on anything else.
#include <cstdint>
#include <cstdlib>

#include "gltf/gltf_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  auto scene = rgbdcast::decode_glb(data, size);
  if (scene.ok()) {
    for (const auto& n : scene->nodes)
      for (auto i : n.mesh.indices)
        if (i >= n.mesh.positions.size()) std::abort();  // an accepted scene is consistent
  } else if (scene.error().message.find('\n') != std::string::npos) {
    std::abort();
  }
  return 0;
}
