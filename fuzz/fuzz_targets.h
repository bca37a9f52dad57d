#pragma once
// The fuzz targets: one function per parser of outside bytes. Each must return normally on any input;
// a crash, a sanitizer report, or an accepted result that breaks its contract (std::abort) is a bug. The libFuzzer
// harness (fuzz_harness.cpp) calls one of them; tests/fuzz replays the seed corpora and every crash input found.
#include <cstddef>
#include <cstdint>

namespace rgbdcast::fuzz {

void glb(const std::uint8_t* data, size_t size);  // decode_glb (POST /v1/scenes body)
// decode_glb on a GLB around a Draco bitstream: u32 declared points (LE), then the bitstream
// (KHR_draco_mesh_compression)
void draco(const std::uint8_t* data, size_t size);
void intrinsics(const std::uint8_t* data, size_t size);    // parse_intrinsics_json
void frame_decode(const std::uint8_t* data, size_t size);  // decode_color, decode_depth16, make_frame
void frame_upload(const std::uint8_t* data, size_t size);  // the multipart frame upload up to the reduction
// POST /v1/scenes with a multipart frame: httplib's parsing, then the route's read and decode (service/upload_body.h)
void multipart(const std::uint8_t* data, size_t size);
void pcd(const std::uint8_t* data, size_t size);         // check_pcd_header, then PCL's reader
void trajectory(const std::uint8_t* data, size_t size);  // TUM, Redwood .log, ICL-NUIM parsers
void view_query(const std::uint8_t* data, size_t size);  // parse_view_request, make_view_camera
void rosbag(const std::uint8_t* data, size_t size);      // open_frame_source on a .bag, then its frames

}  // namespace rgbdcast::fuzz
