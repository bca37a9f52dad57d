// libFuzzer: check_pcd_header on arbitrary bytes, and when it passes, the whole PCD frame read (PCL's reader on a
// file holding the bytes: PCL reads files only).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "input/pcd_source.h"
#include "scene/intrinsics.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  if (!rgbdcast::check_pcd_header(data, size).ok()) return 0;
  static const std::string path = "/tmp/rgbdcast-fuzz-pcd-" + std::to_string(getpid()) + ".pcd";
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  rgbdcast::Intrinsics k;
  k.fx = k.fy = 525.0;
  k.width = 640;
  k.height = 480;
  auto src = rgbdcast::open_pcd_source(path, k);
  if (src.ok()) (void)(*src)->frame(0);
  return 0;
}
