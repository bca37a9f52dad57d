#pragma once
// The ROS bag record check in front of rosbag_storage (rosbag_source.cpp), in a translation unit without ROS headers.
#include <cstddef>
#include <cstdint>
#include <string>

#include "scene/result.h"

namespace rgbdcast {

// rosbag_storage and cpp_common trust the lengths a bag declares (ros::Header::parse reads a field's declared length
// past the end of its record; a chunk's declared size is allocated as given), so rgbdcast walks the whole bag first.
// Contract (rosbag format 2.0): the version line, then records of [u32 header length][header][u32 data length][data],
// each inside the file; a header is fields of [u32 length]["name=value"], each inside its header, with a one-byte
// "op" and the fields rosbag reads for that op, of their sizes; connection data is a header of the same kind with a
// "type". The bag header comes first; its index_pos is the start of a record, where conn_count connection records
// and then chunk_count chunk-info records follow. Every chunk-info names a chunk record (compression none, bz2 or lz4;
// uncompressed size at most 256 MiB, and its data decompresses to exactly that size), which its `count` index records
// follow; an index record's entries point at message records inside that chunk, of a connection the index declares.
// The records inside a chunk obey the same rules (messages and connections only). Errors are kInvalidInput
// "ROS bag: ...", one line, naming the byte offset. Reads the file in bounded pieces (a chunk at a time).
Status check_rosbag_file(const std::string& path);

// The same on bytes in memory (the fuzz target's and the unit tests' entry; check_rosbag_file reads the same way).
Status check_rosbag_bytes(const std::uint8_t* data, size_t size);

// The serialized bytes of one message, walked before ROS deserializes them: ros::serialization resizes a string or
// an array to the length the bytes declare before it finds that fewer bytes follow (a 30 kB bag whose image claims
// 3.27 GB of data made the fuzz target allocate them). Contract: every fixed field, string and array of the
// type's layout (ROS 1 serialization: little-endian, [u32 length] before each string and variable array) lies
// inside [data, data + size); trailing bytes are allowed, as ROS allows them. kInvalidInput with one line naming the
// field otherwise. Types: sensor_msgs/Image and sensor_msgs/CameraInfo, the two RosbagSource deserializes.
enum class RosMessageLayout { kImage, kCameraInfo };
Status check_ros_message(RosMessageLayout layout, const std::uint8_t* data, size_t size);

}  // namespace rgbdcast
