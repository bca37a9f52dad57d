#pragma once
// Reads an encoded image's size from its header without decoding it (JPEG SOF marker, PNG IHDR), so that a hostile
// file cannot make the decoder allocate gigabytes. Returns false when the header cannot be read.
#include <cstddef>
#include <cstdint>

namespace rgbdcast::glb {

bool probe_image_size(const std::uint8_t* data, size_t size, int* width, int* height);

}  // namespace rgbdcast::glb
