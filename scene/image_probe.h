#pragma once
// Reads an encoded image's size from its header without decoding it (PNG IHDR, JPEG SOF marker), so that a hostile
// file cannot make a decoder allocate gigabytes: callers compare the size with their budget first, then decode.
// Contract: reads only data[0, size); returns false when the bytes are neither PNG nor JPEG, the header is cut short,
// or a side is 0 or above INT32_MAX. Pure function, thread-safe, no allocation.
#include <cstddef>
#include <cstdint>

namespace rgbdcast {

bool probe_image_size(const std::uint8_t* data, size_t size, int* width, int* height);

}  // namespace rgbdcast
