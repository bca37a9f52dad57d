#include "input/rosbag_check.h"

#include <bzlib.h>
#include <fcntl.h>
#include <roslz4/lz4s.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <map>
#include <string_view>
#include <vector>

namespace rgbdcast {
namespace {

constexpr std::string_view kMagic = "#ROSBAG V2.0\n";
constexpr std::uint32_t kMaxHeader = 16u << 20;  // one record's header (or a connection's data)
constexpr std::uint32_t kMaxChunk = 256u << 20;  // a chunk's data, compressed or not
constexpr std::uint8_t kMessage = 2, kBagHeader = 3, kIndex = 4, kChunk = 5, kChunkInfo = 6, kConnection = 7;

Error bad(std::uint64_t at, const std::string& why) {
  return make_error(ErrorCode::kInvalidInput, "ROS bag: record at byte " + std::to_string(at) + ": " + why);
}

std::uint64_t le(const std::uint8_t* p, size_t n) {
  std::uint64_t v = 0;
  for (size_t i = n; i-- > 0;) v = (v << 8) | p[i];
  return v;
}

// Reads [offset, offset + n) of the bag into out; false when the bag is shorter.
using ReadAt = std::function<bool(std::uint64_t offset, size_t n, std::uint8_t* out)>;

struct Record {
  std::uint64_t at = 0, data_at = 0, next = 0;
  std::uint32_t data_len = 0;
  std::uint8_t op = 0;
  std::map<std::string, std::string> fields;

  // A field of exactly `size` bytes (little-endian integer), as rosbag's readField requires.
  Result<std::uint64_t> number(const char* name, size_t size) const {
    auto it = fields.find(name);
    if (it == fields.end()) return bad(at, std::string("no '") + name + "' field");
    if (it->second.size() != size)
      return bad(at, std::string("field '") + name + "' has " + std::to_string(it->second.size()) + " bytes, not " +
                         std::to_string(size));
    return le(reinterpret_cast<const std::uint8_t*>(it->second.data()), size);
  }
};

// Fields of [u32 length]["name=value"], each inside [p, p + n) (ros::Header::parse does not check this).
Result<std::map<std::string, std::string>> parse_fields(const std::uint8_t* p, size_t n, std::uint64_t at,
                                                        const char* what) {
  std::map<std::string, std::string> fields;
  size_t i = 0;
  while (i < n) {
    if (n - i < 4) return bad(at, std::string(what) + ": a field length is cut off");
    const std::uint64_t len = le(p + i, 4);
    i += 4;
    if (len > n - i)
      return bad(at, std::string(what) + ": a field claims " + std::to_string(len) + " bytes, " +
                         std::to_string(n - i) + " remain");
    const std::string_view field(reinterpret_cast<const char*>(p + i), len);
    const size_t eq = field.find('=');
    if (eq == std::string_view::npos || eq == 0) return bad(at, std::string(what) + ": a field is not name=value");
    fields[std::string(field.substr(0, eq))] = std::string(field.substr(eq + 1));
    i += len;
  }
  return fields;
}

// One record's header (and its data's position) at `at`, inside [at, end).
Result<Record> read_record(const ReadAt& read, std::uint64_t at, std::uint64_t end) {
  Record r;
  r.at = at;
  std::uint8_t len[4];
  if (end - at < 4 || !read(at, 4, len)) return bad(at, "the header length is cut off");
  const std::uint64_t header_len = le(len, 4);
  if (header_len > kMaxHeader) return bad(at, "a header of " + std::to_string(header_len) + " bytes");
  if (header_len > end - at - 4)
    return bad(
        at, "the header claims " + std::to_string(header_len) + " bytes, " + std::to_string(end - at - 4) + " remain");
  std::vector<std::uint8_t> header(header_len);
  if (!read(at + 4, header_len, header.data())) return bad(at, "the header is cut off");
  auto fields = parse_fields(header.data(), header.size(), at, "header");
  if (!fields) return fields.error();
  r.fields = std::move(*fields);
  const std::uint64_t data_len_at = at + 4 + header_len;
  if (end - data_len_at < 4 || !read(data_len_at, 4, len)) return bad(at, "the data length is cut off");
  r.data_len = static_cast<std::uint32_t>(le(len, 4));
  r.data_at = data_len_at + 4;
  if (r.data_len > end - r.data_at)
    return bad(
        at, "the data claims " + std::to_string(r.data_len) + " bytes, " + std::to_string(end - r.data_at) + " remain");
  r.next = r.data_at + r.data_len;
  auto op = r.fields.find("op");
  if (op == r.fields.end() || op->second.size() != 1) return bad(at, "no one-byte 'op' field");
  r.op = static_cast<std::uint8_t>(op->second[0]);
  return r;
}

// Every named field present with its size.
Status need(const Record& r, std::initializer_list<std::pair<const char*, size_t>> names) {
  for (const auto& [name, size] : names)
    if (auto v = r.number(name, size); !v) return v.error();
  return ok_status();
}

Result<std::vector<std::uint8_t>> read_data(const ReadAt& read, const Record& r) {
  std::vector<std::uint8_t> data(r.data_len);
  if (!read(r.data_at, r.data_len, data.data())) return bad(r.at, "the data is cut off");
  return data;
}

// A connection record: its id, and data that is itself a header with a "type".
Status check_connection(const ReadAt& read, const Record& r, std::map<std::uint32_t, bool>* connections) {
  auto conn = r.number("conn", 4);
  if (!conn) return conn.error();
  if (!r.fields.count("topic")) return bad(r.at, "a connection without a 'topic'");
  if (r.data_len > kMaxHeader) return bad(r.at, "a connection header of " + std::to_string(r.data_len) + " bytes");
  auto data = read_data(read, r);
  if (!data) return data.error();
  auto header = parse_fields(data->data(), data->size(), r.at, "connection header");
  if (!header) return header.error();
  if (!header->count("type")) return bad(r.at, "a connection header without a 'type'");
  (*connections)[static_cast<std::uint32_t>(*conn)] = true;
  return ok_status();
}

// A compressed chunk's data into *plain, which must come to exactly `size` bytes. Memory follows what the data
// really holds, not the size it claims: bz2 output grows as it arrives (bz2 can expand a few bytes into megabytes);
// lz4 (rosbag's framing, at most 255 bytes out per byte in) is allocated once when the claim is possible at all.
bool inflate(const std::string& compression, std::vector<std::uint8_t>& in, std::uint32_t size,
             std::vector<std::uint8_t>* plain) {
  if (compression == "lz4") {
    if (size > 256.0 * in.size() + 65536) return false;
    plain->resize(size);
    unsigned int out = size;
    return roslz4_buffToBuffDecompress(reinterpret_cast<char*>(in.data()), static_cast<unsigned int>(in.size()),
                                       reinterpret_cast<char*>(plain->data()), &out) == ROSLZ4_OK &&
           out == size;
  }
  bz_stream z{};
  if (BZ2_bzDecompressInit(&z, 0, 0) != BZ_OK) return false;
  z.next_in = reinterpret_cast<char*>(in.data());
  z.avail_in = static_cast<unsigned int>(in.size());
  size_t produced = 0;
  int rc = BZ_OK;
  while (rc == BZ_OK) {
    if (produced == plain->size()) {
      if (plain->size() > size) break;  // one byte more than claimed
      plain->resize(std::min<size_t>(size_t(size) + 1, std::max<size_t>(1u << 20, plain->size() * 2)));
    } else if (z.avail_in == 0) {
      break;  // the data ends before the bz2 stream does
    }
    z.next_out = reinterpret_cast<char*>(plain->data() + produced);
    z.avail_out = static_cast<unsigned int>(plain->size() - produced);
    rc = BZ2_bzDecompress(&z);
    produced = plain->size() - z.avail_out;
  }
  BZ2_bzDecompressEnd(&z);
  plain->resize(produced);
  return rc == BZ_STREAM_END && produced == size;
}

struct Chunk {
  std::uint64_t end = 0;                            // the chunk record's end in the file
  std::map<std::uint32_t, std::uint32_t> messages;  // message record offset in the uncompressed data -> connection
};

// A chunk record: the compression, the uncompressed size, and the records inside it.
Result<Chunk> check_chunk(const ReadAt& read, const Record& r, std::map<std::uint32_t, bool>* connections) {
  auto it = r.fields.find("compression");
  if (it == r.fields.end()) return bad(r.at, "a chunk without 'compression'");
  const std::string compression = it->second;
  auto size = r.number("size", 4);
  if (!size) return size.error();
  if (compression != "none" && compression != "bz2" && compression != "lz4")
    return bad(r.at, "chunk compression is not none, bz2 or lz4");
  if (*size > kMaxChunk || r.data_len > kMaxChunk)
    return bad(r.at,
               "a chunk of " + std::to_string(std::max<std::uint64_t>(*size, r.data_len)) + " bytes (at most 256 MiB)");
  if (compression == "none" && *size != r.data_len)
    return bad(r.at, "an uncompressed chunk's size " + std::to_string(*size) + " is not its data length " +
                         std::to_string(r.data_len));
  auto data = read_data(read, r);
  if (!data) return data.error();
  std::vector<std::uint8_t> plain;
  if (compression == "none") {
    plain = std::move(*data);
  } else if (!inflate(compression, *data, static_cast<std::uint32_t>(*size), &plain)) {
    return bad(r.at, "the " + compression + " chunk does not decompress to its size " + std::to_string(*size));
  }
  const ReadAt inside = [&plain](std::uint64_t offset, size_t n, std::uint8_t* out) {
    if (offset > plain.size() || n > plain.size() - offset) return false;
    if (n) std::memcpy(out, plain.data() + offset, n);
    return true;
  };
  Chunk chunk;
  chunk.end = r.next;
  for (std::uint64_t at = 0; at < plain.size();) {
    auto inner = read_record(inside, at, plain.size());
    if (!inner) return bad(r.at, "inside the chunk, " + inner.error().message.substr(std::strlen("ROS bag: ")));
    if (inner->op == kMessage) {
      auto conn = inner->number("conn", 4);
      if (!conn) return conn.error();
      if (auto t = inner->number("time", 8); !t) return t.error();
      chunk.messages[static_cast<std::uint32_t>(at)] = static_cast<std::uint32_t>(*conn);
    } else if (inner->op == kConnection) {
      if (auto st = check_connection(inside, *inner, connections); !st)
        return bad(r.at, "inside the chunk, " + st.error().message.substr(std::strlen("ROS bag: ")));
    } else {
      return bad(r.at, "inside the chunk, a record of op " + std::to_string(inner->op));
    }
    at = inner->next;
  }
  return chunk;
}

Status check(const ReadAt& read, std::uint64_t size) {
  std::uint8_t magic[kMagic.size()];
  if (size < kMagic.size() || !read(0, kMagic.size(), magic) || std::memcmp(magic, kMagic.data(), kMagic.size()) != 0)
    return make_error(ErrorCode::kInvalidInput, "ROS bag: not a rosbag 2.0 file (no '#ROSBAG V2.0' line)");

  std::vector<Record> top;                               // the top-level records in file order (data not kept)
  std::map<std::uint64_t, Chunk> chunks;                 // by the chunk record's offset
  std::map<std::uint64_t, std::vector<Record>> indexes;  // the index records following each chunk
  std::map<std::uint32_t, bool> connections;             // every connection id a connection record declares
  std::uint64_t last_chunk = 0;
  for (std::uint64_t at = kMagic.size(); at < size;) {
    auto r = read_record(read, at, size);
    if (!r) return r.error();
    if ((r->op == kBagHeader) != top.empty())
      return bad(at, top.empty() ? "the first record is not the bag header" : "a second bag header");
    switch (r->op) {
      case kBagHeader:
        if (auto st = need(*r, {{"index_pos", 8}, {"conn_count", 4}, {"chunk_count", 4}}); !st) return st;
        break;
      case kChunk: {
        auto c = check_chunk(read, *r, &connections);
        if (!c) return c.error();
        chunks[at] = std::move(*c);
        last_chunk = at;
        break;
      }
      case kIndex: {
        if (!last_chunk || (top.back().op != kChunk && top.back().op != kIndex))
          return bad(at, "an index record that does not follow a chunk");
        if (auto st = need(*r, {{"ver", 4}, {"conn", 4}, {"count", 4}}); !st) return st;
        if (*r->number("ver", 4) != 1) return bad(at, "index version is not 1");
        if (r->data_len != *r->number("count", 4) * 12) return bad(at, "index data is not 12 bytes per entry");
        indexes[last_chunk].push_back(*r);
        break;
      }
      case kConnection:
        if (auto st = check_connection(read, *r, &connections); !st) return st;
        break;
      case kChunkInfo:
        if (auto st = need(*r, {{"ver", 4}, {"chunk_pos", 8}, {"start_time", 8}, {"end_time", 8}, {"count", 4}}); !st)
          return st;
        if (*r->number("ver", 4) != 1) return bad(at, "chunk info version is not 1");
        if (r->data_len != *r->number("count", 4) * 8) return bad(at, "chunk info data is not 8 bytes per entry");
        break;
      default:
        return bad(at, "a top-level record of op " + std::to_string(r->op));
    }
    at = r->next;
    top.push_back(std::move(*r));
  }
  if (top.empty()) return bad(kMagic.size(), "no bag header");

  // What Bag::open reads: conn_count connections and chunk_count chunk infos from index_pos, then for every chunk
  // info its chunk's header and the index records after it.
  const Record& header = top.front();
  const std::uint64_t index_pos = *header.number("index_pos", 8);
  const std::uint64_t conn_count = *header.number("conn_count", 4), chunk_count = *header.number("chunk_count", 4);
  if (index_pos == 0) return bad(header.at, "the bag is not indexed (index_pos 0; `rosbag reindex` repairs it)");
  size_t i = 0;
  while (i < top.size() && top[i].at != index_pos) ++i;
  if (i == top.size()) return bad(header.at, "index_pos " + std::to_string(index_pos) + " is not a record's start");
  if (top.size() - i < conn_count + chunk_count)
    return bad(index_pos, "the index holds fewer than conn_count + chunk_count records");
  for (size_t k = 0; k < conn_count; ++k)
    if (top[i + k].op != kConnection) return bad(top[i + k].at, "not a connection record (conn_count)");
  for (size_t k = conn_count; k < conn_count + chunk_count; ++k) {
    const Record& info = top[i + k];
    if (info.op != kChunkInfo) return bad(info.at, "not a chunk info record (chunk_count)");
    const std::uint64_t pos = *info.number("chunk_pos", 8);
    auto c = chunks.find(pos);
    if (c == chunks.end()) return bad(info.at, "chunk_pos " + std::to_string(pos) + " is not a chunk record");
    auto entries = read_data(read, info);
    if (!entries) return entries.error();
    for (size_t e = 0; e + 8 <= entries->size(); e += 8)
      if (!connections.count(static_cast<std::uint32_t>(le(entries->data() + e, 4))))
        return bad(info.at, "chunk info names an unknown connection");
    const auto& idx = indexes[pos];
    const std::uint64_t count = *info.number("count", 4);
    if (idx.size() < count)
      return bad(info.at, "chunk info announces " + std::to_string(count) + " index records, the chunk has " +
                              std::to_string(idx.size()));
    for (size_t k2 = 0; k2 < count; ++k2) {
      const Record& index = idx[k2];
      const auto conn = static_cast<std::uint32_t>(*index.number("conn", 4));
      if (!connections.count(conn)) return bad(index.at, "an index of an unknown connection");
      auto data = read_data(read, index);
      if (!data) return data.error();
      for (size_t e = 0; e + 12 <= data->size(); e += 12) {
        auto m = c->second.messages.find(static_cast<std::uint32_t>(le(data->data() + e + 8, 4)));
        if (m == c->second.messages.end() || m->second != conn)
          return bad(index.at, "an index entry that is not a message of its connection in the chunk");
      }
    }
  }
  return ok_status();
}

}  // namespace

Status check_rosbag_bytes(const std::uint8_t* data, size_t size) {
  return check(
      [data, size](std::uint64_t offset, size_t n, std::uint8_t* out) {
        if (offset > size || n > size - offset) return false;
        if (n) std::memcpy(out, data + offset, n);
        return true;
      },
      size);
}

Status check_rosbag_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return make_error(ErrorCode::kNotFound, "ROS bag: cannot open the file");
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    return make_error(ErrorCode::kInvalidInput, "ROS bag: cannot read the file");
  }
  Status result = check(
      [fd](std::uint64_t offset, size_t n, std::uint8_t* out) {
        size_t done = 0;
        while (done < n) {
          const ssize_t got = ::pread(fd, out + done, n - done, static_cast<off_t>(offset + done));
          if (got <= 0) return false;
          done += static_cast<size_t>(got);
        }
        return true;
      },
      static_cast<std::uint64_t>(st.st_size));
  ::close(fd);
  return result;
}

namespace {

// Walks ROS 1 serialized fields over [p, p + n): fixed sizes, and [u32 count] x element size for strings and
// variable arrays. The first field that does not fit is remembered with its name.
class MessageWalk {
 public:
  MessageWalk(const std::uint8_t* p, size_t n) : p_(p), n_(n) {}
  MessageWalk& fixed(const char* name, size_t bytes) {
    if (!failed_ && n_ - at_ < bytes) fail(name, bytes);
    if (!failed_) at_ += bytes;
    return *this;
  }
  MessageWalk& array(const char* name, size_t element_bytes) {
    fixed(name, 4);
    if (failed_) return *this;
    const std::uint64_t bytes = le(p_ + at_ - 4, 4) * element_bytes;
    if (bytes > n_ - at_) fail(name, bytes);
    if (!failed_) at_ += static_cast<size_t>(bytes);
    return *this;
  }
  MessageWalk& header() { return fixed("header.seq", 4).fixed("header.stamp", 8).array("header.frame_id", 1); }
  Status status(const char* type) const {
    if (!failed_) return ok_status();
    return make_error(ErrorCode::kInvalidInput, std::string(type) + " message of " + std::to_string(n_) + " bytes: '" +
                                                    field_ + "' claims " + std::to_string(claim_) + " bytes at byte " +
                                                    std::to_string(at_) + ", " + std::to_string(n_ - at_) + " remain");
  }

 private:
  void fail(const char* name, std::uint64_t bytes) {
    failed_ = true;
    field_ = name;
    claim_ = bytes;
  }
  const std::uint8_t* p_;
  size_t n_, at_ = 0;
  bool failed_ = false;
  const char* field_ = "";
  std::uint64_t claim_ = 0;
};

}  // namespace

Status check_ros_message(RosMessageLayout layout, const std::uint8_t* data, size_t size) {
  MessageWalk w(data, size);
  w.header().fixed("height", 4).fixed("width", 4);
  if (layout == RosMessageLayout::kImage) {
    w.array("encoding", 1).fixed("is_bigendian", 1).fixed("step", 4).array("data", 1);
    return w.status("sensor_msgs/Image");
  }
  w.array("distortion_model", 1).array("D", 8).fixed("K", 72).fixed("R", 72).fixed("P", 96);
  w.fixed("binning_x", 4).fixed("binning_y", 4).fixed("roi", 17);
  return w.status("sensor_msgs/CameraInfo");
}

}  // namespace rgbdcast
